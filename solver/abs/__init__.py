"""Scene kind "abs": a slider with an arbitrary air-bearing surface in partial contact with a rough disk."""
