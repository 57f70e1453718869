"""Campaigns: many seeded runs of whole cells (scenarios x variants x seeds) on Dask distributed,
their results in one parquet table, with statistics and plots (issue #16).

`spec` reads a campaign file, `worker` runs one cell in a Dask worker, `store` keeps the rows,
`engine` schedules the runs (a `LocalCluster` or a scheduler's address), `analysis` writes the
summary, the tests and the plots. Nothing here is imported by `hrc-drake --help`.
"""
