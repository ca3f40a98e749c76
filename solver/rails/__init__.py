"""Scene kind "rails": a taper-flat slider on two rails, impacts at the rail corners (Benson, Chiang & Talke 1989)."""
