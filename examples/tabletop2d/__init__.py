"""A 2-D tabletop pick-and-place domain, written only through guided-tamp's public interface.

Copy this folder to start a domain of your own; docs/domains.md walks through it file by file.
"""
