kneesim_add_benchmark(model MODULES model)
