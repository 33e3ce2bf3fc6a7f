kneesim_add_benchmark(id MODULES dynamics)
