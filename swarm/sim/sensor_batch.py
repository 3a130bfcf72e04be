"""The mine sensors of a batch of runs (`swarm.sim.world`), stepped together.

`SensorBatch.step` does for every run what `MineSensor.update` does for one, with the same draws
from each run's own generator, so a run finds the same mines alone or in a batch:

- a run whose sensor has nothing to do (no pass in progress, no sensing robot in a bin next to a
  target mine of its run, no long jump, no false alarm to draw for) is skipped: `update` would
  draw nothing and find nothing; only its robots' last positions move on;
- Koopman's inverse-cube looks (`MineSensor._looks`) of every run are computed in one pass: the
  same screen (`_maybe_near`'s bins), the same pairs (the dense distance check, each run with its
  own radius), the same look integrals, then each run draws its own uniforms, in its own
  (robot, mine) order; a run with too many pairs for the dense check, and every run of a sensor
  that draws once per pass, goes through its own `update`;
- then each run's false alarms, from the same generator, after its looks.
"""

from __future__ import annotations

import math

import numpy as np

from swarm.sim import draws, pair_kernels
from swarm.sim.comms import sorted_unique
from swarm.sim.sensing import _NEIGHBOUR_BINS, DENSE_PAIRS, SCREEN_MARGIN_M, Detection, MineSensor

_BIN_OFFSET = 1 << 21
_RUN_STRIDE = 1 << 44


class SensorBatch:
    """The sensors of B runs of n robots (None: a run without a search); `dirty(b)` after run b's
    targets change (a find, a blast, the clearance)."""

    def __init__(self, sensors: list[MineSensor | None], n: int) -> None:
        self.sensors = sensors
        self.n = n
        self.runs = len(sensors)
        live = [s for s in sensors if s is not None]
        self.size = (live[0].range_m + SCREEN_MARGIN_M) if live else 1.0
        self.false_alarms = bool(live) and live[0].false_alarms_per_m > 0
        self._dirty = np.ones(self.runs, bool)
        self._keys = np.empty(0, np.int64)
        self._key_len = np.zeros(self.runs, np.int64)  # each run's screen keys
        self._key_at = np.zeros(self.runs + 1, np.int64)  # where each run's keys start
        self._per_run: list[np.ndarray] = [np.empty(0, np.int64)] * self.runs
        # each run's mines and which are targets, padded to the largest field (NaN, False), and
        # its mine count and sensor range: kept by `_refresh`, as the screen keys are
        self._mine_xy = np.full((self.runs, 0, 2), np.nan)
        self._target = np.zeros((self.runs, 0), bool)
        self._mine_count = np.zeros(self.runs, np.int64)
        self._range = np.zeros(self.runs)
        self._discrete = np.zeros(self.runs, bool)  # a sensor that is not `continuous`
        self._present = np.zeros(self.runs, bool)  # a run with a sensor

    def dirty(self, b: int) -> None:
        self._dirty[b] = True

    @staticmethod
    def _bin_keys(bins: np.ndarray, run: np.ndarray | int) -> np.ndarray:
        bins = bins + _BIN_OFFSET
        return np.asarray(run, np.int64) * _RUN_STRIDE + (bins[:, 0] << 22) + bins[:, 1]

    def _refresh(self) -> None:
        """Each dirty run's screen keys (the bins around its target mines, `_maybe_near`'s) and its
        rows of the mine and target arrays `_looks` reads."""
        dirty = [self.sensors[b] for b in np.flatnonzero(self._dirty).tolist()]
        # every other run's field fits the rows already (it was refreshed before)
        width = max((s._m for s in dirty if s is not None), default=0)
        if width > self._target.shape[1]:  # a larger field (a reset): every run's rows anew
            self._mine_xy = np.full((self.runs, width, 2), np.nan)
            self._target = np.zeros((self.runs, width), bool)
            self._dirty[:] = True
        for b in np.flatnonzero(self._dirty).tolist():
            s = self.sensors[b]
            keys = np.empty(0, np.int64)
            self._mine_xy[b] = np.nan
            self._target[b] = False
            self._mine_count[b] = 0 if s is None else s._m
            self._discrete[b] = s is not None and not s.continuous
            self._present[b] = s is not None
            if s is not None and s._m:
                field = s.minefield
                target = field.active & ~field.detected
                self._mine_xy[b, : s._m] = field.positions_m
                self._target[b, : s._m] = target
                self._range[b] = s.range_m
                if target.any():
                    bins = np.floor(field.positions_m[target] / self.size).astype(np.int64)
                    around = (bins[:, None, :] + _NEIGHBOUR_BINS[None, :, :]).reshape(-1, 2)
                    keys = sorted_unique(self._bin_keys(around, b))
            self._per_run[b] = keys
            self._key_len[b] = len(keys)
        self._dirty[:] = False
        # the run is the keys' leading part (`_RUN_STRIDE`), so runs in order are sorted keys
        self._keys = np.concatenate(self._per_run)
        np.cumsum(self._key_len, out=self._key_at[1:])

    def step(
        self,
        xy: np.ndarray,
        last_xy: np.ndarray,
        sensing: np.ndarray,
        alive: np.ndarray,
        distance_m: np.ndarray,
        runs: list[int],
        t_s: np.ndarray,
        rngs: list[np.random.Generator | None],
    ) -> dict[int, list[Detection]]:
        """One step of the sensors of runs `runs`: arrays (B * n, ...) over every robot of the batch,
        run-major (`sensing` already without non-finite positions; `last_xy` each sensor's last
        positions, which this moves on); `t_s` (B,) each run's time, `rngs[b]` its sensing
        stream. Returns each run's reports (mines found, then false alarms), as `update`; a run
        that reports nothing may be left out."""
        n = self.n
        out: dict[int, list[Detection]] = {}
        if self.runs == 1:  # one run: its sensor's own update, nothing to share
            s = self.sensors[0]
            if s is not None and runs:
                out[0] = s.update(xy, sensing, distance_m, float(t_s[0]), rngs[0], alive=alive)
            return out
        if self._dirty.any():
            self._refresh()
        who = np.flatnonzero(sensing)
        run = who // n
        # robots in a bin next to a target of their run (`_maybe_near`'s screen; exact for any
        # point within 2^21 bins, 10,000 km, of the origin, as every robot on a map is), and robots
        # that jumped further than the screen's margin: those are looked at by their run's update
        in_bins, jumped = pair_kernels.screen(xy, last_xy, who, n, self.size, self._keys, self._key_at,
                                              _BIN_OFFSET, _RUN_STRIDE, SCREEN_MARGIN_M**2)  # fmt: skip
        busy = self._discrete.copy()  # a sensor that draws once per pass: its own update
        busy[run[in_bins]] = True
        busy[run[jumped]] = True
        near_run = np.zeros(self.runs, bool)
        near_run[run[in_bins]] = True
        jump_run = np.zeros(self.runs, bool)
        jump_run[run[jumped]] = True
        alarm_run = np.zeros(self.runs, bool)
        if self.false_alarms:
            alarm_run = (sensing & (distance_m > 0)).reshape(self.runs, n).any(axis=1)
            busy |= alarm_run
        if len(runs) < self.runs:
            stepped = np.zeros(self.runs, bool)
            stepped[runs] = True
            busy &= stepped
        # every other run's sensor is continuous with no robot near a target, none that jumped and
        # no false alarm to draw for: it has nothing to do (a continuous sensor never has passes
        # in progress: only `MineSensor._passes` keeps them)
        busy &= self._present
        own = busy & (self._discrete | jump_run)  # through the run's own update
        rest = busy & ~own
        look = rest & near_run & (self._mine_count > 0)
        for b in np.flatnonzero(own).tolist():
            s = self.sensors[b]
            if near_run[b] or jump_run[b] or alarm_run[b] or len(s._keys):
                rows = slice(b * n, (b + 1) * n)
                out[b] = s.update(xy[rows], sensing[rows], distance_m[rows], float(t_s[b]), rngs[b],
                                  alive=alive[rows])  # fmt: skip
        out.update({b: [] for b in np.flatnonzero(rest & ~look & alarm_run).tolist()})
        looks = np.flatnonzero(look).tolist()
        if len(looks) == 1:  # one run looks: its own `_looks`, the same draws
            b = looks[0]
            rows = slice(b * n, (b + 1) * n)
            out[b] = self.sensors[b]._looks(xy[rows], sensing[rows], float(t_s[b]), rngs[b])
        elif looks:
            wanted = np.zeros(self.runs, bool)
            wanted[looks] = True
            self._looks(xy, last_xy, sensing, who[wanted[run] & in_bins], t_s, rngs, out)
        for b in np.flatnonzero(rest).tolist() if self.false_alarms else ():  # after the looks
            s = self.sensors[b]
            if b in out:
                rows = slice(b * n, (b + 1) * n)
                out[b] = out[b] + s._false_alarms(
                    xy[rows], sensing[rows], distance_m[rows], float(t_s[b]), rngs[b]
                )
        # the last positions of every run stepped (the updates above set their own the same way)
        if len(runs) == self.runs:
            last_xy.fill(np.nan)
            np.copyto(last_xy, xy, where=sensing[:, None])
            return out
        rows = np.repeat(stepped, n)
        last_xy[rows & ~sensing] = np.nan
        keep = rows & sensing
        last_xy[keep] = xy[keep]
        return out

    def _looks(self, xy, last_xy, sensing, robots, t_s, rngs, out) -> None:
        """`MineSensor._looks` for the screened `robots` (global rows, run-major) of `runs`: the
        pairs and look integrals of every run at once, then each run's uniforms from its own
        generator; only a run with a hit goes on to `MineSensor._found`."""
        n = self.n
        start, end, run, ids, dense, r, j, at = pair_kernels.screened_pairs(
            xy, last_xy, robots, n, self._range, self._mine_count, self._mine_xy, self._target, DENSE_PAIRS
        )
        for b in ids[~dense].tolist():  # too many pairs for one pass over its mines: its own grid search
            rows = slice(b * n, (b + 1) * n)
            out[b] = self.sensors[b]._looks(xy[rows], sensing[rows], float(t_s[b]), rngs[b])
        if self.false_alarms:  # a run looked at gets its false alarms after its finds (`step`)
            out.update({b: [] for b in ids[dense].tolist()})
        # each run's uniforms in its pairs' order (a run without pairs, dense or not, draws none)
        u = np.empty(len(r))
        draws.fill_uniform(rngs, ids, at, u)
        if not len(r):
            return
        look = pair_kernels.pair_looks(start, end, self._mine_xy, run, r, j)
        hazard = self.sensors[int(ids[0])].sensor.width_m ** 2 / (8.0 * math.pi) * look
        hits = np.flatnonzero(u < -np.expm1(-hazard))
        if not len(hits):
            return
        hit = np.zeros(len(r), bool)
        hit[hits] = True
        for k in np.unique(np.searchsorted(at, hits, side="right") - 1).tolist():
            b = int(ids[k])
            lo, hi = at[k], at[k + 1]
            mine = hit[lo:hi]
            local = robots[r[lo:hi][mine]] - b * n
            out[b] = self.sensors[b]._found(local, j[lo:hi][mine], float(t_s[b]))
