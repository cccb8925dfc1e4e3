"""Learned stream models (Bradley & Roy): features, per-stream MLPs, training.

``features`` turns a stream query (encoded inputs, some possibly unbound, and the fluent facts of
the plan's state) into a fixed-length vector and needs no torch; ``model`` holds the per-stream
networks (``CostModel``, a model file) and ``train`` fits them on recorded stream queries. Torch
is imported by ``model`` and ``train`` only, so importing this package stays cheap.
"""
