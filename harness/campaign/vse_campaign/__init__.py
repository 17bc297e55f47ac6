"""Campaigns of co-simulations on Dask distributed: a campaign file expands into cases,
chunks of cases run on Dask workers through the Rust harness (`harness cases`), results go to
Parquet chunk by chunk, and a summary is written at the end. `python -m vse_campaign --help`."""
