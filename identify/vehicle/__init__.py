"""What the tyre does to the car: steady-state cornering, transient handling and ride of a
vehicle on a .tir at chosen front/rear pressures (``mfid vehicle``, docs/vehicle.md).

Modules: :mod:`.spec` (the vehicle file), :mod:`.tyre` (the .tir at the axles),
:mod:`.steady` (two-track steady state, ISO 4138), :mod:`.transient` (single track with tyre
lag, ISO 7401), :mod:`.ride` (quarter car on an ISO 8608 road), :mod:`.analysis` (all of it
per pressure setting).
"""
