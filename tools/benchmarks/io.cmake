kneesim_add_benchmark(io MODULES io)
