"""The grid TAMP after PDDLStream's discrete_tamp example (docs/domains.md)."""
