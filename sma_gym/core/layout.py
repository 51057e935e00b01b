"""Field layout of the simulator core's state and parameter matrices.

The core works on two float64 matrices with one row per actuator (actuator-major):
``state[i, S_*]`` and ``params[i, P_*]``. Keeping everything in two contiguous arrays
makes a call into the compiled kernel cheap (two arrays to unbox instead of forty), keeps
each actuator's data together in memory, and lets every actuator carry its own parameters:
one env, a multiplexed bank, a vector env of thousands with randomised conditions, or a
batch of candidate models in a fit all use the same code. The integer constants below are
compile-time constants for numba.

Only compiled code and :class:`sma_gym.simulator.Simulator` index these matrices. Everyone
else reads the simulator's named views (``sim.position_m``, ``sim.usable_stroke_m``, ...,
each an array over actuators) or :meth:`~sma_gym.simulator.Simulator.read` by the names in
:data:`STATE_NAMES`.

How to add a parameter
----------------------
1. ``sma_gym/params.py``: a field with a default and a docstring (symbol, unit, value,
   source) on the part it belongs to (:class:`~sma_gym.params.Wire`, ``Driver``, ...), and
   its range as a ``Bound`` row of that part's ``_BOUNDS`` table (a test checks that every
   numeric field has one). Presets and ``with_changes("part.field")`` follow from the
   dataclass. Model files name every parameter and a file without one is refused (a 0.5 mm
   wire's file without its diameter once ran as the 0.3 mm wire), so files saved before the
   field existed stop loading: give it a default that reproduces the model without it,
   accept its absence in ``ActuatorParams.from_dict`` as the migration there does for the
   phases' expansion coefficients, and add it to ``sma_gym/models/*.json``.
2. This module: a ``P_*`` constant after the last one, and ``N_PARAMS`` moved to one past
   it (nothing depends on the order of the others). Derived quantities (areas, time
   constants, scaled coefficients) get their own constant and are computed once at packing
   time, not in the kernel.
3. ``sma_gym/simulator.py`` :func:`~sma_gym.simulator.pack_params`: one line
   ``col[L.P_NEW] = <part>.<field>`` (or the derived value).
4. Compiled code: read ``params[i, P_NEW]`` where the term is computed (``core/kernel.py``
   reads parameters into locals and passes them to the ``physics``/``electrical`` functions,
   which take scalars so they can be tested on their own; a constant of the implicit
   mechanics step becomes a field of ``physics.mechanics.WireConstants``). Import the
   constant by name.
5. Nothing to delete: a cached compiled function is keyed on every file of
   ``sma_gym._jit.COMPILED_SOURCES`` (the modules that define compiled code, and this
   one), so any edit of them recompiles it at the next import (25-40 s). A new module
   with compiled functions goes into that list (a test checks it).
6. If an env or user should see it: a named view on ``Simulator`` (parameters) or a name
   in :data:`STATE_NAMES` (state; then it is recordable by ``Simulator.run`` too).

How to add an effect
--------------------
An effect is an optional term that is off (vanishes) at its *off* value.

1. ``sma_gym/effects/__init__.py``: declare it (name, parameters with unit, off value,
   bounds, forms, the outputs it changes; a parameter's name ends in its unit, as
   ``force_n``, and a test checks the two agree). The diagnosis workflow picks it up as a
   candidate from there, so a new effect changes what every diagnosis weighs: if it is
   nearly degenerate with a refitted nominal parameter (a loss proportional to T - T_amb
   is a convection level), declare that in ``diagnosis.fitting.DEGENERATE_WITH_NOMINAL``
   and ``diagnosis.workflow.SEPARATING_EXPERIMENTS``, expect
   ``tests/test_diagnosis.py``'s every-effect test to say whether it can be named, and
   rerun the benchmarks and the twin (docs/diagnosis.md) before quoting their figures.
2. Its parameters go through steps 2-4 above; in :func:`~sma_gym.simulator.pack_params`
   read them with ``fx.value("<effect>", "<parameter>")``. If it has several forms, the
   physics module that implements the term maps each form name to a numeric code
   (``FRICTION_FORMS = {"default": FRICTION_COULOMB, "stribeck": ...}``) and pack_params
   stores ``FRICTION_FORMS[fx.form("coulomb_friction")]`` in a ``P_*_FORM`` field; a test
   checks that every declared form has its code.
3. Write the term in the physics module it belongs to so that the off value makes it
   vanish exactly (the report's model must stay bit for bit the same):
   ``tests/test_simulator.py`` pins the nominal model's numbers, so a term that does not
   vanish fails there. A term in the heat balance goes into the sub-step's rate bound in
   ``core/kernel.py`` too (it restates the balance to size the step), and the page of the
   model (docs/model.md §4 or §2, and §11's table) describes it.
4. A new state quantity (a filter stage, an accumulator): an ``S_*`` constant below, its
   start value in ``Simulator.reset``, and step 5 above.
"""

from __future__ import annotations

MAX_SPREAD_NODES = 7

# --------------------------------------------------------------------------------------
# State fields: state[i, S_*] of actuator i
# --------------------------------------------------------------------------------------
S_X = 0  # position (contraction) x [m]
S_V = 1  # velocity x' [m/s]
S_T = 2  # wire temperature T [degC]
S_SIGMA = 3  # wire stress sigma [Pa]
S_XI = 4  # martensite fraction xi (mean over spread nodes) [-]
S_XI_NODE0 = 5  # martensite fraction of each spread sub-element [-]
S_FILTER = S_XI_NODE0 + MAX_SPREAD_NODES  # position-sensor low-pass filter output [m]
S_LAG1 = S_FILTER + 1  # sensor_lag effect, first stage [m]
S_LAG2 = S_LAG1 + 1  # sensor_lag effect, second stage (second-order form) [m]
S_DIRECTION = S_LAG2 + 1  # last direction of motion, +1 contracting / -1 extending
S_TRAVEL = S_DIRECTION + 1  # accumulated travel [m] (abbe_offset 'wear' form)
S_EOT_CUT = S_TRAVEL + 1  # 1 while the driver's end-of-travel cut is active
S_PWM_TAU = S_EOT_CUT + 1  # time since the start of the current PWM period [s] (resolved mode)
S_DUTY_CMD = S_PWM_TAU + 1  # duty commanded for the last control step (after clipping)
S_DUTY_LATCHED = S_DUTY_CMD + 1  # duty of the current PWM period (resolved mode)
S_POS_MEAS = S_DUTY_LATCHED + 1  # last position reading [m]
S_R_MEAS = S_POS_MEAS + 1  # last resistance reading V/I [ohm], NaN if none could be taken
S_I_MEAS = S_R_MEAS + 1  # last current reading (on-time) [A], NaN if none
S_V_MEAS = S_I_MEAS + 1  # last wire-voltage reading (on-time) [V], NaN if none
S_R_TRUE = S_V_MEAS + 1  # wire resistance now [ohm]
S_POWER = S_R_TRUE + 1  # mean electrical power into the wire over the last control step [W]
S_E_ELECTRIC = S_POWER + 1  # electrical energy into the wire since reset [J]
S_E_CONVECTED = S_E_ELECTRIC + 1  # heat lost to the surroundings since reset [J]
S_W_MECHANICAL = S_E_CONVECTED + 1  # work done by the wire on the mechanism since reset [J]
S_E_DISSIPATED = S_W_MECHANICAL + 1  # energy dissipated by damping and friction since reset [J]
S_FORCE = S_E_DISSIPATED + 1  # bias-spring force k x + F_pre [N]
S_TIME = S_FORCE + 1  # simulated time since reset [s]
S_T_RESET = S_TIME + 1  # temperature at the last reset [degC] (energy balance)
S_E_LATENT = S_T_RESET + 1  # latent heat released into the wire since reset [J]
S_T_SURR = S_E_LATENT + 1  # temperature of the air and parts the wire convects to [degC]
# Where in its PWM period the pulse starts, as a fraction of the period: commanded (written by
# Simulator.set_pulse_start, 0 = at the period start, the fixed slots' layout) and latched at
# each period start like the duty (resolved mode; a shared-budget driver lays pulses end to end).
S_PULSE_START_CMD = S_T_SURR + 1  # [-]
S_PULSE_START = S_PULSE_START_CMD + 1  # latched start of the current period's pulse [s]
N_STATE = S_PULSE_START + 1

STATE_NAMES = {
    S_X: "position_m",
    S_V: "velocity_m_s",
    S_T: "temperature_c",
    S_SIGMA: "stress_pa",
    S_XI: "martensite_fraction",
    S_FILTER: "position_filtered_m",
    S_POS_MEAS: "position_measured_m",
    S_R_MEAS: "resistance_measured_ohm",
    S_I_MEAS: "current_measured_a",
    S_V_MEAS: "voltage_measured_v",
    S_R_TRUE: "resistance_ohm",
    S_POWER: "power_w",
    S_E_ELECTRIC: "electrical_energy_j",
    S_E_CONVECTED: "convected_heat_j",
    S_W_MECHANICAL: "mechanical_work_j",
    S_E_DISSIPATED: "dissipated_energy_j",
    S_FORCE: "spring_force_n",
    S_TIME: "time_s",
    S_DUTY_CMD: "duty",
    S_EOT_CUT: "end_of_travel_cut",
    S_E_LATENT: "latent_heat_released_j",
    S_T_SURR: "surroundings_temperature_c",
}
"""Public names of the state fields (the simulator's view names, ``Simulator.run`` records)."""
STATE_FIELDS = {name: index for index, name in STATE_NAMES.items()}

# --------------------------------------------------------------------------------------
# Parameter fields: params[i, P_*] of actuator i (all SI; derived quantities are
# precomputed at packing time)
# --------------------------------------------------------------------------------------
# wire geometry and thermal mass
P_AREA = 0  # A [m^2]
P_LENGTH = 1  # l0 [m]
P_HEAT_CAP = 2  # m c_p [J/K]
P_SPECIFIC_HEAT = 3  # c_p [J/(kg K)]
P_SURFACE = 4  # A_c [m^2]
# convection, already scaled for the diameter and by convection_change
P_H0 = 5  # [W/(m^2 K)]
P_H1 = 6  # [W/(m^2 K^2)] (convection_change)
P_H2 = 7  # [W/(m^2 K^3)]
P_CONV_FORM = 8  # 0: h0 + h1 dT + h2 T^2; 1: 'power' form (synthetic data only)
P_CONV_POWER_SCALE = 9  # multiplier of the power form
P_T_AMB = 10  # [degC]
# elasticity and transformation
P_D_A = 11  # [Pa]
P_D_M = 12  # [Pa]
P_EPS0 = 13  # [-]
P_ALPHA_TH_A = 14  # thermal expansion of austenite [1/K]
P_C_A = 15  # [Pa/K]
P_C_M = 16  # [Pa/K]
P_A_S = 17  # [degC]
P_A_F = 18  # [degC]
P_M_S = 19  # [degC]
P_M_F = 20  # [degC]
P_LATENT = 21  # latent heat per unit xi while heating (M->A), Delta_H / c_p [K]
P_LATENT_COOL = 22  # the same while cooling (A->M) [K]
P_N_NODES = 23  # number of hysterons (sub-elements) of the transformation, 1..MAX_SPREAD_NODES
P_NODE_HEAT0 = 24  # shift of each hysteron's heating branch (M->A) [K], MAX_SPREAD_NODES rows
P_NODE_COOL0 = P_NODE_HEAT0 + MAX_SPREAD_NODES  # shift of each hysteron's cooling branch [K]
P_NODE_WEIGHT0 = P_NODE_COOL0 + MAX_SPREAD_NODES  # weight of each hysteron [-]
_NODE_END = P_NODE_WEIGHT0 + MAX_SPREAD_NODES
# resistance
P_RHO_M = _NODE_END  # [ohm m]
P_RHO_A = _NODE_END + 1  # [ohm m]
P_TCR_M = _NODE_END + 2  # [1/K]
P_TCR_A = _NODE_END + 3  # [1/K]
P_T_REF_R = _NODE_END + 4  # [degC]
# mechanism
P_MASS = _NODE_END + 5  # [kg]
P_DAMPING = _NODE_END + 6  # [N s/m]
P_K_SPRING = _NODE_END + 7  # [N/m]
P_F_PRE = _NODE_END + 8  # [N]
P_SIGMA0 = _NODE_END + 9  # F_pre / A [Pa]
P_F_COULOMB = _NODE_END + 10  # coulomb_friction [N]
P_FRICTION_FORM = _NODE_END + 11  # 0 Coulomb, 1 Stribeck
# driver and supply
P_V_SUPPLY = _NODE_END + 12  # [V]
P_R_SERIES = _NODE_END + 13  # supply_sag [ohm]
P_SAG_FORM = _NODE_END + 14  # 0 resistor, 1 quadratic
P_SAG_I_REF = _NODE_END + 15  # reference current of the quadratic form [A]
P_PWM_PERIOD = _NODE_END + 16  # [s]
P_PWM_PHASE = _NODE_END + 17  # start of this actuator's period, as a fraction of the period (multiplexer)
P_DUTY_MAX = _NODE_END + 18  # largest duty this actuator may get (1/n when multiplexed)
P_RESOLVED = _NODE_END + 19  # 1 = PWM-resolved, 0 = PWM-averaged
P_T_SETTLE = _NODE_END + 20  # measurement settling after switch-on [s]
P_TAU_RISE = _NODE_END + 21  # pulse_settling time constant [s]
P_RISE_FORM = _NODE_END + 22  # 0 exponential rise, 1 pure delay
P_EOT = _NODE_END + 23  # end-of-travel cut position [m] (inf = none)
P_EOT_RELEASE = _NODE_END + 24  # [m]
# sensors
P_TAU_FILTER = _NODE_END + 25  # position filter time constant [s] (0 = none)
P_TAU_LAG = _NODE_END + 26  # sensor_lag [s]
P_LAG_ORDER = _NODE_END + 27  # 1 or 2
P_ABBE = _NODE_END + 28  # abbe_offset [m]
P_ABBE_FORM = _NODE_END + 29  # 0 step, 1 wear
P_POS_NOISE = _NODE_END + 30  # [m]
P_POS_RESOLUTION = _NODE_END + 31  # [m]
P_R_NOISE = _NODE_END + 32  # [ohm]
P_I_NOISE = _NODE_END + 33  # [A]
P_V_NOISE = _NODE_END + 34  # [V]
# integrator
P_H_MAX = _NODE_END + 35  # largest integration sub-step [s]
P_DT_MAX = _NODE_END + 36  # largest temperature change per sub-step [K]
P_DX_MAX = _NODE_END + 37  # largest position change per sub-step [m]
# derived, for the task layer (observation scales, reward); unused by the physics
P_STROKE = _NODE_END + 38  # usable stroke [m] (ActuatorParams.usable_stroke_m)
P_R_COLD = _NODE_END + 39  # cold resistance [ohm] (Wire.cold_resistance_ohm)
# warm_surroundings effect (0 gain: the wire convects to the ambient temperature)
P_SURR_GAIN = _NODE_END + 40  # surroundings' warming per joule the wire convects [K/J]
P_SURR_TAU = _NODE_END + 41  # surroundings' relaxation time to the ambient [s]
P_SURR_FORM = _NODE_END + 42  # physics.thermal.SURROUNDINGS_FORMS
# integrator, in the end-of-travel cut's switching band (see core.kernel)
P_DT_BAND = _NODE_END + 43  # largest temperature change per sub-step in the band [K]
P_DX_BAND = _NODE_END + 44  # largest position change per sub-step in the band [m]
P_ALPHA_TH_M = _NODE_END + 45  # thermal expansion of martensite [1/K]
N_PARAMS = P_ALPHA_TH_M + 1

PARAM_FIELDS = {name[2:].lower(): index for name, index in list(globals().items()) if name.startswith("P_")}
