"""The solver's exceptions, in one place.

Every failure of a computation that a scene can legitimately cause (no flying equilibrium, a stalled solve,
an impact the contact law cannot resolve) is a :class:`SolverError`. Its ``hint`` says what a user can try;
the command line prints the message and the hint on one line, and a study records them with the run.
"""

from __future__ import annotations


class SolverError(RuntimeError):
    """A computation that found no answer for this scene (not a bug: a property of the scene or the numerics)."""

    #: What a user can try, printed after the message.
    hint = ""

    def __init__(self, message: str, hint: str | None = None) -> None:
        super().__init__(message)
        if hint is not None:
            self.hint = hint


class SteadyFilmError(SolverError):
    """A steady Reynolds solve that did not converge."""

    hint = "a finer grid (numerics.nx, numerics.ny) or a starting attitude nearer the flight"


class AttitudeError(SolverError):
    """The steady attitude search (force and moment balance) did not converge."""

    hint = (
        "another grid (numerics.nx, numerics.ny), a larger preload (suspension.preload) or, for a partial-contact "
        "scene, a weaker adhesion (contact.delta_gamma): where adhesion pulls harder than the air bearing can push "
        "there is no flying equilibrium"
    )


class ContactError(SolverError):
    """An impact that the contact law cannot resolve."""

    hint = "a smaller time step (numerics.dt) or a different disturbance (initial.*)"


class ElasticContactError(SolverError):
    """The complementarity problem of the elastic contact could not be solved."""

    hint = 'the asperity contact law (models.contact = "greenwood_williamson") or a finer grid'
