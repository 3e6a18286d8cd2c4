"""The benchmark: batched simulation of the paper's studies, metrics, plots and the CLI."""
