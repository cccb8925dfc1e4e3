"""The 2-D pick-and-place after PDDLStream's continuous_tamp example (docs/domains.md)."""
