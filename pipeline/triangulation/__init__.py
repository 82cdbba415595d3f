"""triangulation stage."""
