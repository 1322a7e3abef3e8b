"""One module per DVC stage plus the benchmark harness. May import `ynet`, never the reverse."""
