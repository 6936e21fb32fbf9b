"""One module per reproduced experiment: inputs -> a result record (and figures)."""
