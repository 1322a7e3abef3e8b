"""Speed benchmarks and the prepared GPU check (bench/README.md), run from the repository root as
`python -m bench.<name>`: a package, so that a benchmark imports its siblings as `bench.<name>`."""
