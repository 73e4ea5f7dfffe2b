"""
Merging frames into jobs that share footprints, through an engine
(:class:`~radiosim.kernels.engines.Engine`): a :class:`FootprintGroup` holds its members' stacked
moments (:class:`~radiosim.kernels.Members`), takes one engine pass per frame (or block of up
to :data:`FRAME_BLOCK` consecutive frames) and distinct response with a signal table (the
signal T needs none: a linear job's moments come from the first pass), and merges it into
every member active in it. The integrator's engine pass
(:class:`radiosim.integrator.EnginePass`) builds the groups and reads their moments.

The members are the integrator's per-job records (``first``, ``stop``, ``weights``, ``job``
with its ``integrator`` and ``response``, and ``group``, ``slot``, ``has_signal`` set here);
a response hands its signal's tables to the engine through ``signal_table(frame)``
(:class:`~radiosim.kernels.table.SignalTable`, or ``None`` when the signal is T).
"""

from __future__ import annotations

import numpy as np

from radiosim.kernels.engines import Engine
from radiosim.kernels.reference import Members

__all__ = ["FootprintGroup", "FRAME_BLOCK", "frame_runs", "crop"]


class FootprintGroup:
    """Jobs that share footprints: one reference, one kernel pass per frame and response, and
    their accumulators stacked (:class:`radiosim.kernels.Members`) so the kernel merges the
    frame into every job itself."""

    def __init__(self, integrator, engine: Engine):
        self.integrator = integrator
        self.engine = engine
        self.members: list = []
        self.reference = None
        self.state = None

    def start(self):
        self.state = Members(len(self.members), self.integrator.shape)
        for b, m in enumerate(self.members):
            m.group, m.slot = self, b
        self.first = min(m.first for m in self.members)
        self.stop = max(m.stop for m in self.members)

    def passes(self, start: int, stop: int) -> tuple[np.ndarray, list, np.ndarray]:
        """For frames start … stop − 1: the members' time weights (frames × members, 0 when
        inactive); per distinct response of the members active in any of those frames (in
        order of appearance), the response and those members; and which frames any member's
        window holds."""
        weight = np.zeros((stop - start, len(self.members)))
        active = np.zeros(stop - start, dtype=bool)
        by_response: dict[int, list] = {}
        for b, m in enumerate(self.members):
            first, last = max(start, m.first), min(stop, m.stop)
            if first < last:
                weight[first - start:last - start, b] = m.weights[first - m.first:last - m.first]
                active[first - start:last - start] = True
                by_response.setdefault(id(m.job.response), [m.job.response, []])[1].append(b)
        return weight, list(by_response.values()), active

    def merge(self, temperature: np.ndarray, sample, start: int):
        """Merge frames ``start``, ``start + 1``, … (``temperature``: one 2-D frame over the
        group's region, or a 3-D block of consecutive frames; ``sample``: the first one's
        scene frame, for its emissivity) into the members active in them: one kernel pass per
        distinct response with a signal table, or one pass if there is none (the first forms
        the moments: :meth:`_ordered`). Frames no member's window holds
        are skipped (neither read nor checked, as frame by frame); with more than one pass,
        frames go one at a time, so that an error names the earliest bad frame of any pass.
        Consecutive frames go together only while the same responses are active in the same
        order (their passes are then those of each frame alone)."""
        block = temperature if temperature.ndim == 3 else temperature[None]
        n = block.shape[0]
        order = self._responses_by_frame(start, n)
        f = 0
        while f < n:
            if not order[f]:
                f += 1
                continue
            _, passes, _ = self.passes(start + f, start + f + 1)
            step = n if len(self._ordered(passes, sample)) == 1 else 1
            g = f + 1
            while g < n and order[g] == order[f] and g - f < step:
                g += 1
            self._merge_run(block[f:g] if g - f > 1 else block[f], sample, start + f)
            f = g

    def _responses_by_frame(self, start: int, n: int) -> list[tuple]:
        """For frames start … start + n − 1: the responses of the members whose windows hold
        it, in the order of their first such member (as :meth:`passes` orders them); empty
        where none does."""
        order = [[] for _ in range(n)]
        for m in self.members:
            for k in range(max(start, m.first) - start, min(start + n, m.stop) - start):
                if id(m.job.response) not in order[k]:
                    order[k].append(id(m.job.response))
        return [tuple(o) for o in order]

    def _merge_run(self, temperature: np.ndarray, sample, start: int):
        """:meth:`merge` of consecutive frames that members' windows hold."""
        n = 1 if temperature.ndim == 2 else temperature.shape[0]
        weight, passes, _ = self.passes(start, start + n)
        rows, cols = self.integrator.rows, self.integrator.cols
        if self.reference is None:  # [K] per pixel: the first frame's means
            first = temperature if temperature.ndim == 2 else temperature[0]
            self.reference = self.engine.pixel_mean(first, rows, cols, frame_index=start)
        moments_done = False
        for table, members, keep in self._ordered(passes, sample):
            signal_weight = np.zeros(weight.shape)
            if table is not None:
                signal_weight[:, members] = weight[:, members]
                for b in members:
                    self.members[b].has_signal = True
            self.engine.accumulate_merged(temperature, rows, cols, self.reference,
                                          self.state, weight, signal_weight, table,
                                          moments=not moments_done, keep_moments=keep,
                                          frame_index=start)
            moments_done = True

    @staticmethod
    def _ordered(passes: list, sample) -> list:
        """The engine passes of :meth:`passes`' responses: (signal table or None, members,
        keep_moments). The first pass forms the moments (the signal T needs no pass of its
        own); when the first response's signal is T and another's has a table, that table's
        pass comes first and forms them (``keep_moments``: rows below its table keep the
        moments a pass without it gives), so one pass reads the frame instead of two, with the
        same results."""
        tables = [(response.signal_table(sample), members) for response, members in passes]
        if tables and tables[0][0] is None:
            radiometric = [k for k, (table, _) in enumerate(tables) if table is not None]
            if radiometric:
                first = radiometric[0]
                return ([(tables[first][0], tables[first][1], True)]
                        + [(t, m, False) for k, (t, m) in enumerate(tables)
                           if k != first and t is not None])
        return [(t, m, False) for k, (t, m) in enumerate(tables) if k == 0 or t is not None]


#: Consecutive frames one kernel call takes from a scene that holds its frames as one array
#: (:meth:`~radiosim.scenes.base.Scene.block_unchecked`).
FRAME_BLOCK = 128


def frame_runs(indices: list[int], size: int) -> list[tuple[int, int]]:
    """Sorted frame indices as (start, stop) runs of consecutive frames, each ≤ ``size``."""
    runs = []
    for k in indices:
        if runs and runs[-1][1] == k and k - runs[-1][0] < size:
            runs[-1][1] = k + 1
        else:
            runs.append([k, k + 1])
    return [tuple(r) for r in runs]


def crop(values: np.ndarray, outer: tuple, inner: tuple) -> np.ndarray:
    """The part of a frame, or of a block of frames, read over ``outer`` that covers ``inner``
    (a view)."""
    return values[..., inner[0].start - outer[0].start:inner[0].stop - outer[0].start,
                 inner[1].start - outer[1].start:inner[1].stop - outer[1].start]
