"""Web layer: REST API, run store, jobs, CLI (and the 3D scene)."""
