"""Physical constants used across the simulator (SI units)."""

from scipy.constants import epsilon_0 as _epsilon_0

#: Speed of light in vacuum, m/s (exact, SI 2019).
SPEED_OF_LIGHT = 299_792_458.0

#: Boltzmann constant, J/K (exact, SI 2019).
BOLTZMANN = 1.380_649e-23

#: Reference noise temperature T0 of the noise factor definition, K (IEEE Std 161).
T0 = 290.0

#: Vacuum permittivity, F/m (CODATA 2022, ``scipy.constants.epsilon_0``): the value Sionna RT uses to turn
#: a conductivity into a complex permittivity, so a material defined here and read back by Sionna is exact.
VACUUM_PERMITTIVITY = float(_epsilon_0)
