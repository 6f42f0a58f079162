"""A tag population's record values (rfsim.devices.tag_population.TagPopulation.record_values):
the tuples an exchange's record holds, shared between exchanges while the arrays are equal."""

from __future__ import annotations

import math

import numpy as np

from rfsim.channels import Antenna, Isotropic
from rfsim.core.rng import trial_rng
from rfsim.devices.tag import PassiveTag, TagConfig


def _population(n=4):
    tags = [PassiveTag(TagConfig(epc_hex=f"{k + 1:024X}"),
                       Antenna(position_m=(1.0 + k, 0.0, 1.0), orientation=(0.0, 0.0, 0.0), pattern=Isotropic(),
                               polarization="circular"), rng=trial_rng(5, k)) for k in range(n)]
    return PassiveTag.population(tags)


def test_record_values_are_the_arrays_as_tuples():
    pop = _population()
    dbm = np.array([-3.5, -7.25, math.nan, -20.0])
    powered = np.array([True, True, False, False])
    rv = pop.record_values(dbm, powered)
    assert type(rv.incident_power_dbm) is tuple and type(rv.powered) is tuple
    assert rv.incident_power_dbm[:2] == (-3.5, -7.25) and math.isnan(rv.incident_power_dbm[2])
    assert rv.incident_power_dbm[3] == -20.0
    assert rv.powered == (0, 1)
    assert all(type(v) is float for v in rv.incident_power_dbm) and all(type(i) is int for i in rv.powered)


def test_record_values_shared_while_equal_to_the_bit_and_new_on_any_change():
    pop = _population()
    dbm = np.array([-3.5, -7.25, math.nan, -20.0])
    powered = np.array([True, True, False, False])
    first = pop.record_values(dbm, powered)
    dbm[0] = 0.0  # the arrays given are copied: changing them afterwards changes nothing held
    again = pop.record_values(np.array([-3.5, -7.25, math.nan, -20.0]), powered.copy())
    assert again.incident_power_dbm is first.incident_power_dbm and again.powered is first.powered
    one_power = pop.record_values(np.array([-3.5, -7.25, math.nan, -20.5]), powered)
    assert one_power.incident_power_dbm is not first.incident_power_dbm and one_power.incident_power_dbm[3] == -20.5
    one_state = pop.record_values(np.array([-3.5, -7.25, math.nan, -20.5]), np.array([True, False, False, False]))
    assert one_state.powered == (0,)
    signed_zero = pop.record_values(np.array([-3.5, -7.25, math.nan, -0.0]), np.array([True, False, False, False]))
    again_zero = pop.record_values(np.array([-3.5, -7.25, math.nan, 0.0]), np.array([True, False, False, False]))
    assert again_zero.incident_power_dbm is not signed_zero.incident_power_dbm  # compared to the bit
    assert math.copysign(1.0, again_zero.incident_power_dbm[3]) == 1.0
