"""The dashboard server (FastAPI); imports from ``planner``, never the other way round."""
