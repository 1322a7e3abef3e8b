"""Command-line tools around the pipeline (`make repro`'s clock and Dask runner, what a params
change re-runs, re-recording fingerprints, running the studies), run from the repository root as
`python -m tools.<name>`: a package, so that a tool imports its siblings as `tools.<name>`."""
