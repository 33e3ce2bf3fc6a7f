kneesim_add_benchmark(seating MODULES contact)
