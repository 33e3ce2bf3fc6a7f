kneesim_add_benchmark(contact_area MODULES contact DEPENDS kneesim_distance_fcl LIBS ${CMAKE_DL_LIBS})
