kneesim_add_benchmark(ik MODULES ik)
