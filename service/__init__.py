"""Everything with I/O: command line, pose logs (MCAP), database, REST API, alerts, batch jobs."""
