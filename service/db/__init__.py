"""Storage: the schema, sessions, ingest of gait results, aggregates, baselines, alerts, erasure."""
