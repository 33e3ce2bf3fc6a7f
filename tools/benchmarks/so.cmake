kneesim_add_benchmark(so MODULES muscle tool)
