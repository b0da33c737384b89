"""The caregivers' REST API (FastAPI): ``create_app`` in ``service.api.app``."""
