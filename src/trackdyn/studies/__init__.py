"""Studies: many independent simulations run through Dask, gathered into one table."""
