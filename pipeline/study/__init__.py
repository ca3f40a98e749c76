"""Studies: study files and their cases, boundary bisection, multi-fidelity planning."""
