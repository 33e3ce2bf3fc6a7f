"""kneesim from Python: models, inverse kinematics, file formats, contact area, contact-law
identification and the sim-to-real gap diagnosis of the kneesim engine (C++).

Units are SI throughout (m, rad, s, N, m^2). Arrays are NumPy float64 arrays; NumPy is loaded
only when a function first needs it. Bad input raises kneesim.InputError (a ValueError) whose
message is the engine's one line "file:line: element: expected X, got Y"; its attributes file,
line, element and message hold the parts (None where unknown).

See docs/python.md for every function with an example.
"""

from ._kneesim import (  # noqa: F401  (the public API)
    AnalogTable,
    Body,
    C3d,
    C3dParameter,
    ContactArea,
    Coordinate,
    FitResult,
    ForcePlate,
    IkResult,
    InputError,
    InternalError,
    Joint,
    MarkerTable,
    Marker,
    Mesh,
    Model,
    Storage,
    fit_contact_law,
    load_model,
    read_c3d,
    read_marker_file,
    read_storage,
    read_trc,
    run_contact_area,
    run_gap,
    run_ik,
    solve_ik,
    write_c3d,
    write_storage,
    write_trc,
)

__version__ = "@PROJECT_VERSION@"

__all__ = [name for name in dir() if not name.startswith("_")]
