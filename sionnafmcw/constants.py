"""Physical constants used across the simulator (SI units)."""

#: Speed of light in vacuum, m/s (exact, SI 2019).
SPEED_OF_LIGHT = 299_792_458.0

#: Boltzmann constant, J/K (exact, SI 2019).
BOLTZMANN = 1.380_649e-23

#: Reference noise temperature T0 of the noise factor definition, K (IEEE Std 161).
T0 = 290.0
