"""Alembic migrations of the gaitwatch database (run through ``gaitwatch db upgrade``).

The Alembic configuration is built in code (``service.db.migrate.alembic_config``) with
``script_location`` pointing at this package, so migrations work from an installed package
without an ``alembic.ini``.
"""
