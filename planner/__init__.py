"""guided-tamp planning core: problem language, abstract planning, streams, search, learning."""

__version__ = "0.1.0"
