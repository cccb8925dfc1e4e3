"""One router per resource (the runs, catalogs and the 3D view are in :mod:`app.api`)."""
