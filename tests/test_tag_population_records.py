"""A tag population's record values (rfsim.devices.tag_population.TagPopulation.record_values):
the tuples an exchange's record holds, shared between exchanges while the arrays are equal; an
exchange's (PopulationReflection.record_values) are its arrays' values, kept with the round while
the reacting members keep the round's values."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from rfsim.channels import Antenna, Isotropic
from rfsim.core.rng import trial_rng
from rfsim.devices.tag import PassiveTag, TagConfig
from rfsim.devices.tag_population import PopulationReflection, _Round


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


def _round(powered, dbm):
    """The fields of a round's quiet points that an exchange's records are made of."""
    n = len(powered)
    return SimpleNamespace(powered=np.array(powered), dbm=np.array(dbm, dtype=float), known=np.ones(n, bool),
                           scatter=np.zeros(n, bool), record=None, stays_on=np.array(powered),
                           stays_off=~np.array(powered))


def _exchange(pop, rnd, reactions):
    """A population's reflection in which the members of ``reactions`` ({j: (powered, dBm)}) reacted."""
    quiet = np.ones(len(rnd.powered), bool)
    quiet[list(reactions)] = False
    return PopulationReflection(pop, rnd, quiet, {j: SimpleNamespace(powered=p, incident_power_dbm=d)
                                                  for j, (p, d) in reactions.items()}, [])


def test_exchange_record_values_are_its_arrays_whether_or_not_the_reacting_members_keep_the_rounds_values():
    pop = _population()
    rnd = _round([True, True, False, False], [-3.5, -7.25, -30.0, 0.0])
    cases = {"as the round": {1: (True, -7.25)}, "power state": {1: (False, -7.25)},
             "incident power": {1: (True, -7.5)}, "signed zero": {3: (False, -0.0)}, "none": {}}
    for name, reactions in cases.items():
        ex = _exchange(pop, rnd, reactions)
        rv = ex.record_values()
        assert rv.incident_power_dbm == tuple(ex.incident_power_dbm.tolist()), name
        assert [math.copysign(1.0, v) for v in rv.incident_power_dbm] == [
            math.copysign(1.0, v) for v in ex.incident_power_dbm], name
        assert rv.powered == tuple(np.flatnonzero(ex.powered).tolist()), name
    assert _exchange(pop, rnd, {1: (False, -7.25)}).record_values().powered == (0,)
    assert _exchange(pop, rnd, {1: (True, -7.5)}).record_values().incident_power_dbm[1] == -7.5
    assert math.copysign(1.0, _exchange(pop, rnd, {3: (False, -0.0)}).record_values().incident_power_dbm[3]) == -1.0


def test_exchange_record_values_kept_with_the_round_until_a_quiet_point_becomes_known():
    pop = _population()
    rnd = _round([True, True, False, False], [-3.5, -7.25, -30.0, -40.0])
    first = _exchange(pop, rnd, {1: (True, -7.25)}).record_values()
    assert _exchange(pop, rnd, {0: (True, -3.5), 2: (False, -30.0)}).record_values() is first
    _Round._set(rnd, 2, SimpleNamespace(powered=True, p_dbm=-29.0, structural_mode=0.5, gamma_rest=0.1))
    learned = _exchange(pop, rnd, {1: (True, -7.25)}).record_values()
    assert learned.powered == (0, 1, 2) and learned.incident_power_dbm[2] == -29.0
