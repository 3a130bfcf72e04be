"""Monte Carlo studies: the simulator run many times over seeds and parameter grids, locally or on
a Ray cluster, with results in Parquet and success probabilities with confidence intervals."""
