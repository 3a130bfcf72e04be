"""What a plan expects after its losses follows the loss budget: robots lost before they are ashore
search no track, take over none, hold no relay position and come back to no pick-up."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from scipy.stats import binom

from swarm.mission import budget, mission_from_dict
from swarm.mission.plan import plan_json, plan_mission
from swarm.report.plan_report import plan_data

REPO = Path(__file__).resolve().parents[2]


def _eight_by_hand(name: str, surf_s: float, beach_s: float) -> dict:
    """Eight robots put in by hand 20 m off test_small's beach: a mission's head."""
    by_hand = {"platform": "by_hand", "points": ["launch_1", "launch_2"], "offshore_m": 20, "interval_s": 2}
    return {
        "name": name,
        "map": "../maps/test_small.yaml",
        "planner": "../planners/fast.yaml",
        "swarm": {"count": 8},
        "launch": by_hand,
        "phases": {
            "sea_transit": {"time_limit_s": 150},
            "surf_crossing": {"time_limit_s": surf_s},
            "beach_operations": {"time_limit_s": beach_s},
        },
    }


def _mission(mtbf_h: float, **success: float):
    raw = _eight_by_hand("after_losses", 60, 120)
    raw["phases"]["return_to_sea"] = {"enabled": True}
    raw |= {
        "tasks": [
            {
                "type": "relay",
                "source": "relay_source",
                "sinks": ["relay_sink"],
                "radio": {"tx_power_dbm": -10.0, "source_antenna_height_m": 0.7},  # relays needed
            },
            {
                "type": "search",
                "area": "search_beach",
                "sensor": {"sweep_width_m": 5.0},
                "robots": 3,
                "detection_confidence": 0.75,  # what 3 searchers on a 120 s beach can promise
            },
        ],
        "success": success,
        "hazards": {"mines": {"count": 3}, "attrition": {"mtbf_h": mtbf_h}},
    }
    return mission_from_dict(raw, REPO / "missions" / "after_losses.yaml")


CRITERIA = {"min_detection_fraction": 0.05, "min_relay_connected_fraction": 0.5, "min_robots_recovered": 1}


@pytest.fixture(scope="module")
def plans():
    """The same mission with robots that last (MTBF 1000 h) and with every robot failing on the
    swim (MTBF 0.0001 h: 0.36 s)."""
    return {mtbf: plan_mission(_mission(mtbf, **CRITERIA), seed=2, workers=1) for mtbf in (1000.0, 1e-4)}


@pytest.mark.slow
def test_every_robot_lost_on_the_swim_leaves_nothing_to_expect(plans) -> None:
    """mine_clear with every robot expected lost at sea still expected 72.9% detection after
    losses (its reserve, lost too, drove 25 km of takeovers), its relay held and robots back."""
    lasting, gone = plans[1000.0].budget, plans[1e-4].budget
    assert gone["expected_lost"] == pytest.approx(8.0, abs=1e-6)
    assert sum(gone["expected_losses"]["sea"].values()) > 7.9
    (search,) = gone["search"].values()
    assert search["expected_detection"] > 0.05  # as planned, the tracks find mines
    assert search["expected_detection_after_losses"] < 1e-6
    assert search["p_criterion_met_after_losses"] < 1e-6
    assert gone["relay"]["p_held"] < 1e-6
    assert gone["expected_recovered"] == [0.0, 0.0]  # none back: a number, not unknown
    (kept,) = lasting["search"].values()
    assert kept["expected_detection_after_losses"] > 0.05
    assert lasting["relay"]["p_held"] > 0.95  # what the breakers leave
    assert lasting["expected_recovered"][0] > 1.0


@pytest.mark.slow
def test_the_verdict_of_a_plan_whose_robots_are_all_lost_falls_short_on_each_count(plans) -> None:
    """Every check a plan makes after its losses fails when nobody reaches the beach, the relay's
    too (it staffs every position, and the link margins close); with robots that last, each holds."""
    import json

    lasting = plan_data(json.loads(plan_json(plans[1000.0])))["verdict"]
    gone = plan_data(json.loads(plan_json(plans[1e-4])))["verdict"]
    assert lasting["status"] == "met"
    assert gone["status"] == "not met"
    failed = {c["criterion"].split(" (")[0] for c in gone["checks"] if not c["met"]}
    assert failed == {
        "expected detection after losses",
        "P(detection criterion met) after losses",
        "share of the time the relay's positions are held after losses",
        "robots expected back at sea, at least",
    }
    assert all(c["met"] for c in lasting["checks"])


def test_a_robot_is_ashore_for_none_of_its_window_when_lost_afloat() -> None:
    """Lost at sea or in the surf: none of the window; lost ashore at a constant rate: half of it on
    average; both: the product."""
    assert budget.time_ashore({"sea": {"failure": 1.0}, "surf": {}, "beach": {}}) == 0.0
    assert budget.time_ashore({"sea": {}, "surf": {"wave_impact": 1.0}, "beach": {}}) == 0.0
    assert budget.time_ashore({"sea": {}, "surf": {}, "beach": {"failure": 0.4}}) == pytest.approx(0.8)
    both = {"sea": {"failure": 0.5}, "surf": {"wave_impact": 0.2}, "beach": {"failure": 0.4, "mine": 0.5}}
    assert budget.time_ashore(both) == pytest.approx(0.5 * 0.8 * (1.0 - 0.7 / 2.0))


def test_at_least_k_of_independent_chances_is_the_poisson_binomial_tail() -> None:
    rng = np.random.default_rng(3)
    chances = rng.uniform(size=7)
    for k in range(0, 9):
        brute = sum(
            math.prod(p if hit else 1.0 - p for p, hit in zip(chances, pick, strict=True))
            for pick in itertools.product((0, 1), repeat=len(chances))
            if sum(pick) >= k
        )
        assert budget.p_at_least(chances, k) == pytest.approx(brute, abs=1e-12)
    assert budget.p_at_least(np.full(12, 0.3), 5) == pytest.approx(binom.sf(4, 12, 0.3))


@pytest.mark.parametrize(("model", "w", "s"), [("inverse_cube", 3.0, 1.9), ("cookie_cutter", 5.0, 1.0)])
def test_an_undone_band_among_lost_bands_keeps_nothing(model: str, w: float, s: float) -> None:
    """Every searcher lost before its track and none of it taken over: no lane is driven, so no
    strip keeps anything, however far the sensor reaches (the inverse cube's lanes beyond
    `BAND_REACH_LANES` used to count as driven: 10% kept). With nothing lost around it, as before."""
    gone = budget.undone_band_kept(model, w, s, lanes=3.0, left=1.0, undone=1.0, lost=1.0)
    assert gone == pytest.approx(0.0, abs=1e-9)
    some = budget.undone_band_kept(model, w, s, lanes=3.0, left=1.0, undone=1.0, lost=0.5)
    none = budget.undone_band_kept(model, w, s, lanes=3.0, left=1.0, undone=1.0, lost=0.0)
    assert gone < some < none


def _stranding_mission():
    """Eight robots from the beach's edge into 1 m breakers with a 48 s surf crossing: the
    longshore current sets them along the beach, and two searchers are still afloat when the limit
    runs out at every phase of the wave; the survivors' slack before the clearance is short of
    the two lost tracks."""
    raw = _eight_by_hand("surf_stranding", 48, 700) | {
        "tasks": [
            {
                "type": "search",
                "area": "search_beach",
                "sensor": {"sweep_width_m": 5.0},
                "track_spacing_m": 2.5,
                "mark": True,
                "clearance": {"at_s": 850, "standoff_m": 10},
            }
        ],
        "success": {"min_detection_fraction": 0.5},
        "hazards": {"mines": {"count": 30}, "surf": {"wave_height_m": 1.0}},
    }
    return mission_from_dict(raw, REPO / "missions" / "surf_stranding.yaml")


@pytest.fixture(scope="module")
def stranding():
    """The stranding mission, its plan, each robot's way in as the budget counts it, and 16
    simulated runs of the plan."""
    from swarm.mission import exposure
    from swarm.mission.surf_speed import SurfZone
    from swarm.planning.router import Router
    from swarm.sim.run import simulate_batch

    mission = _stranding_mission()
    plan = plan_mission(mission, seed=2, workers=1)
    cm = plan.costmap
    zone = SurfZone(mission, cm)
    ashore = exposure.nearest_ashore(mission, cm, zone.heights > 0)
    router = Router(cm, seed=mission.seed)
    driven = [exposure.drivable(rp, router) for rp in plan.robots]
    mine_area = shapely.union_all(budget.mine_areas(mission))
    by_task = {s.task: s for s in plan.search}
    ways = exposure.ways_in(mission, cm, driven, zone, ashore, mine_area, by_task)
    logs = simulate_batch(mission, list(range(100, 116)), plan=plan, record_every_s=math.inf)
    return plan, ways, logs


def _first(log, robot: str, kind: str) -> float | None:
    """The time of `robot`'s first event of `kind` in the run, None without one."""
    return next((e["t_s"] for e in log.events if e.get("robot") == robot and e["kind"] == kind), None)


def test_the_survivors_time_for_lost_tracks_starts_when_their_own_is_driven(stranding) -> None:
    """Three of eight robots are stranded in the surf and every other searcher takes over lost
    track as soon as its own is done (the first takeover). The budget counts a searcher's time for
    lost tracks from its landing (`ashore_s`, then `at_work_s` at its track) plus its own track as
    stitched (`track_s`): 512 s a searcher from landing against the runs' 513 s. It used to count
    from its entry into the surf (35-45 s before the landing here, 230-410 s at mine_clear's 2 m
    breakers) plus the design's even share of the lanes (390 s), so the survivors had time for
    lost tracks that they spend on their own."""
    plan, ways, logs = stranding
    assert len(plan.budget["stranded_in_surf"]) == 2
    planned, simulated = [], []
    for rp, way in zip(plan.robots, ways, strict=True):
        landed = [t for log in logs if (t := _first(log, rp.id, "ashore")) is not None]
        if landed:  # a robot that lands does so when the plan says
            assert np.mean(landed) == pytest.approx(way.ashore_s, abs=10.0)
            assert way.at_work_s >= np.mean(landed)
        own = [
            t - a
            for log in logs
            if (a := _first(log, rp.id, "ashore")) is not None
            and (t := _first(log, rp.id, "takeover")) is not None
        ]
        if rp.role == "search" and own:
            planned.append(way.at_work_s - way.ashore_s + way.track_s)
            simulated.append(np.mean(own))
    assert len(planned) >= 3
    assert np.mean(planned) == pytest.approx(np.mean(simulated), rel=0.1)
    assert plan.search[0].design["search_time_s"] < 0.85 * np.mean(simulated)  # the design's share


def test_nobody_marks_while_lost_track_is_open(stranding) -> None:
    """The scripted policy hands a mark only to a robot that knows of no open piece of lost track,
    so a reserve marks only in the runs whose lost tracks are all taken over (`budget.p_no_excess`):
    the fewest markers the plan expects are fewer than the reserves that last (here 0.72 of the one
    reserve; at a 60 s limit, before afloat robots made way ashore, 0.03 where the plan said 0.52),
    and the runs expend within the plan's range (2.5 a run)."""
    plan, _, logs = stranding
    least, most = plan.budget["expected_expended"]
    expended = np.mean([log.summary()["end_states"].get("expended", 0) for log in logs])
    reserves = sum(rp.role == "spare" for rp in plan.robots)
    assert reserves == 1 and least < 0.9 * reserves
    assert least <= expended <= most


def test_no_excess_is_the_chance_below_zero_of_the_excess_s_normal() -> None:
    """`p_no_excess` is P(D <= 0) of the normal whose positive part `expected_excess` averages: the
    slope of E[max(D, 0)] in the mean is P(D > 0)."""
    for mean, sd in ((-3000.0, 2000.0), (0.0, 500.0), (1500.0, 800.0)):
        h = 1e-3 * sd
        slope = (budget.expected_excess(mean + h, sd) - budget.expected_excess(mean - h, sd)) / (2 * h)
        assert 1.0 - budget.p_no_excess(mean, sd) == pytest.approx(slope, abs=1e-6)
    assert budget.p_no_excess(-1.0, 0.0) == 1.0
    assert budget.p_no_excess(1.0, 0.0) == 0.0


def test_the_survivors_work_until_the_retreat_and_again_after_the_blast() -> None:
    """mine_clear: the retreat before the 7200 s clearance starts at 7020 s (50 m standoff + 10 m
    at 0.6 m/s, x 1.5, + 30 s), and beach operations run on to 7800 s, when the scripted policy's
    robots drive the lost tracks' pieces again (16 runs at 2 m breakers: 26.4% of the tracks open
    at the retreat, 20.8% at the end)."""
    from swarm.mission import load_mission

    mission = load_mission(REPO / "missions" / "mine_clear.yaml")
    (task,) = mission.tasks_of("search")
    end = budget.takeover_end_s(mission, task)
    assert end == pytest.approx(7020.0)
    assert mission.beach_end_s == 7800.0
    assert budget.takeover_s(mission, task, 1500.0) == pytest.approx(end - 1500.0 + 600.0)
    assert budget.takeover_s(mission, task, 7100.0) == pytest.approx(600.0)  # at work after the retreat
    assert budget.takeover_s(mission, task, 7500.0) == pytest.approx(300.0)


def _search_only(mtbf_h: float, **success):
    """`_mission` without its relay: a run is judged by its mines found alone (unless `success`
    asks for robots back)."""
    raw = _mission(mtbf_h).model_dump(mode="json", exclude_none=True)
    raw = _eight_by_hand("search_only", 60, 120) | {
        "tasks": [t for t in raw["tasks"] if t["type"] == "search"],
        "success": {"min_detection_fraction": 0.3, **success},
        "hazards": raw["hazards"],
    }
    return mission_from_dict(raw, REPO / "missions" / "search_only.yaml")


@pytest.mark.parametrize("mtbf_h", [1000.0, 1e-4])
def test_a_plan_s_chance_of_success_is_its_search_s_after_losses(mtbf_h: float) -> None:
    """A run judged by its mines found alone succeeds with the plan's chance that its search meets
    the criterion after its losses: 3 mines, at least ceil(0.3 x 3) = 1 found, each with the
    detection after losses, binomially; none when every robot is lost on the swim. A run also
    judged by a criterion the plan gives no chance for (robots back, a relay) has none."""
    from swarm.mission.plan import success_chance

    mission = _search_only(mtbf_h)
    assert mission.judged_by == ["detection"]
    plan = plan_mission(mission, seed=2, workers=1)
    (search,) = plan.budget["search"].values()
    after = search["expected_detection_after_losses"]
    assert success_chance(mission, plan) == pytest.approx(binom.sf(0, 3, after), rel=1e-9)
    if mtbf_h < 1:
        assert success_chance(mission, plan) < 1e-6
    else:
        assert 0.5 < success_chance(mission, plan) < 1.0
    back = _search_only(mtbf_h, min_robots_recovered=1)
    assert back.judged_by == ["detection", "recovered"]
    assert success_chance(back, plan) is None


@pytest.mark.parametrize("name", ["mine_clear", "full_conops", "landing", "recon", "relay"])
def test_the_criteria_a_run_is_judged_by_are_the_simulator_s(name: str) -> None:
    """`Mission.judged_by` names the criteria the simulator's score counts (`MissionScore`), for
    every shipped mission and the relay-and-search mission above."""
    from swarm.mission import load_mission
    from swarm.sim.criteria import MissionScore

    for mission in (load_mission(REPO / "missions" / f"{name}.yaml"), _mission(10.0, **CRITERIA)):
        relays = mission.tasks_of("relay")
        score = MissionScore(mission, relays[0].redundancy if relays else None, n_mines=3)
        assert mission.judged_by == list(score.values())


def test_a_marker_expended_at_the_blast_is_not_lost_by_the_clock_after_it() -> None:
    """mine_clear's markers leave the mission at the blast, 600 s before beach operations end (24
    robots: 13.3 expended a run in 100 runs), and the budget counted random failures for every robot
    to the end. It now takes off as many as halfway between the fewest and most markers it
    expects, each with the chance of failing in those 600 s at the mission's MTBF (10 h): 1 -
    exp(-600 / 36000) = 0.01653; nothing else moves."""
    from swarm.mission import load_mission
    from swarm.mission import plan as planning

    mission = load_mission(REPO / "missions" / "mine_clear.yaml")
    after_s = mission.beach_end_s - mission.tasks[0].clearance.at_s
    assert after_s == 600.0
    counted = planning.plan_mission(mission, seed=mission.seed, workers=1).budget
    timed = budget.timed_losses

    def nothing_after_the_blast(m, t_s: float) -> dict[str, float]:
        return {c: 0.0 for c in timed(m, t_s)} if t_s == after_s else timed(m, t_s)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(budget, "timed_losses", nothing_after_the_blast)
        uncounted = planning.plan_mission(mission, seed=mission.seed, workers=1).budget
    markers = sum(counted["expected_expended"]) / 2.0
    assert counted["expected_expended"] == uncounted["expected_expended"] and markers > 5.0
    failed = [b["expected_losses"]["beach"]["failure"] for b in (counted, uncounted)]
    assert failed[1] - failed[0] == pytest.approx(markers * -math.expm1(-600.0 / 36000.0), rel=1e-9)
    assert uncounted["expected_lost"] - counted["expected_lost"] == pytest.approx(failed[1] - failed[0])
