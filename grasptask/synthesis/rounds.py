"""The search route's sweep (SPEC section 12): starts searched in fixed-size rounds, each round's end points
grouped into basins, each new basin polished, best end point first, until one is verified.

A round's rows are handed on when the round is finished: ``polished`` (the paper's NLP from its end point),
``same-basin`` (its basin's polished start, its own end point and force-problem Q) or a search that did not
converge (``search-far``, ``search-nan``). What a round does depends only on its starts and the rounds before it,
and its searches run in batches fixed by the round alone, never on which worker finished first, so the rows are the
same with any number of workers and on Dask.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grasptask.grasp.grasp_pose import Grasp
from grasptask.progress import Progress
from grasptask.records.solutions import failed_row, grasp_columns
from grasptask.synthesis.basins import EndPoint, group, joins
from grasptask.synthesis.clustering import descriptor
from grasptask.synthesis.polish import Polish
from grasptask.synthesis.search import SearchEnd, batches
from grasptask.synthesis.starts import Start

OnRow = Callable[[dict], None]


@dataclass
class Basin:
    """A basin: its id, its end points (best first) and the start whose polish stands for it (None: none yet)."""

    basin_id: int
    members: list[EndPoint]
    polished_start: int | None = None
    verified: bool = False


@dataclass
class Route:
    """How the rounds read and write: the executor, the grasp's names, the object's symmetry and the sizes."""

    executor: Any
    joint_names: list[str]
    fingers: list[str]
    symmetry: dict | None
    round_size: int
    polish_per_basin: int
    batch_size: int
    basins: list[Basin] = field(default_factory=list)

    def run(self, starts: list[Start], on_row: OnRow) -> None:
        """Every start in rounds of :attr:`round_size`, each round's rows handed to ``on_row`` when it ends."""
        rounds = math.ceil(len(starts) / self.round_size)
        for k in range(rounds):
            chunk = starts[k * self.round_size : (k + 1) * self.round_size]
            for row in self.round(chunk, f"round {k + 1}/{rounds}"):
                on_row(row)

    def round(self, starts: list[Start], name: str) -> list[dict]:
        """One round: its starts searched, their end points grouped (joining earlier rounds' basins where they lie
        within them), the new basins polished; a row per start, in start order."""
        ends = self._search(starts, name)
        rows: dict[int, dict] = {}
        points: dict[int, EndPoint] = {}
        for start in starts:
            end = ends[start.start_id]
            if isinstance(end, dict):  # the worker's error, crash or hang: recorded as it is
                rows[start.start_id] = {**end, "outcome": "search-failed"}
            elif not end.converged:
                rows[start.start_id] = self._unsearched(start, end)
            else:
                points[start.start_id] = self._end_point(start.start_id, end)
        fresh = self._assign(group(list(points.values())))
        by_id = {s.start_id: s for s in starts}
        polished = self._polish(fresh, by_id, ends, name)
        basin_of = {m.start_id: b for b in self.basins for m in b.members}
        for start_id, point in points.items():
            basin, end = basin_of[start_id], ends[start_id]
            assert isinstance(end, SearchEnd)
            if start_id in polished:  # its seconds and iterations: the search's and the polish's
                row = polished[start_id]
                spent = {"seconds": row["seconds"] + end.seconds, "iterations": row["iterations"] + end.iterations}
                rows[start_id] = {**row, **spent, **self._searched(end, point, basin, "polished")}
            else:
                rows[start_id] = self._joined(by_id[start_id], end, point, basin)
        return [rows[s.start_id] for s in starts]

    def _search(self, starts: list[Start], name: str) -> dict[int, SearchEnd | dict]:
        """The round's starts searched in fixed batches (:func:`~grasptask.synthesis.search.batches`); a batch
        whose worker failed is that failure's row for each of its starts."""
        ends: dict[int, SearchEnd | dict] = {}
        jobs = batches(starts, self.batch_size)
        members = {job.start_id: job.starts for job in jobs}
        with Progress(len(starts), f"search {name}", "starts") as shown:

            def done(result: Any) -> None:
                if isinstance(result, dict):  # the worker's error, crash or hang, for every start of its batch
                    for start in members[result["start_id"]]:
                        ends[start.start_id] = {**result, "start_id": start.start_id, "orientation": start.orientation,
                                                "position": start.position_name}  # fmt: skip
                    shown.update(len(members[result["start_id"]]))
                    return
                for end in result:
                    ends[end.start_id] = end
                converged = sum(isinstance(e, SearchEnd) and e.converged for e in ends.values())
                shown.update(len(result), converged=converged)

            self.executor.run(jobs, done)
        return ends

    def _end_point(self, start_id: int, end: SearchEnd) -> EndPoint:
        grasp = end.grasp
        assert end.forces is not None and grasp is not None
        described = descriptor(grasp.contacts, grasp.palm_position, grasp.palm_rotation[:, 2], self.symmetry)
        return EndPoint(start_id, described, end.forces.Q, end.forces.value)

    def _assign(self, groups: list[list[EndPoint]]) -> list[Basin]:
        """Each group joined to an earlier round's basin it lies within, or made a new basin; the new ones."""
        fresh = []
        for members in groups:
            earlier = next((b for b in self.basins if joins(members[0], b.members)), None)
            if earlier is not None:
                earlier.members.extend(members)
                continue
            basin = Basin(len(self.basins), members)
            self.basins.append(basin)
            fresh.append(basin)
        return fresh

    def _polish(self, fresh: list[Basin], starts: dict[int, Start], ends: dict[int, Any], name: str) -> dict[int, dict]:
        """Each new basin's end points polished, best first, in waves until one is verified or
        :attr:`polish_per_basin` were tried; the polished rows by start."""
        polished: dict[int, dict] = {}
        waiting = list(fresh)
        with Progress(len(fresh), f"polish {name}", "basins") as shown:
            for wave in range(self.polish_per_basin):
                chosen = [b.members[wave].start_id for b in waiting if wave < len(b.members)]
                tasks = [Polish(starts[start_id], ends[start_id]) for start_id in chosen]
                if not tasks:
                    break
                results = self._run_polishes(tasks)
                still = []
                for basin in waiting:
                    if wave >= len(basin.members):
                        continue
                    start_id = basin.members[wave].start_id
                    row = results[start_id]
                    polished[start_id] = row
                    basin.polished_start = start_id
                    if row.get("verified"):
                        basin.verified = True
                        shown.update(1, verified=sum(b.verified for b in fresh))
                    else:
                        still.append(basin)
                waiting = still
            shown.update(len(waiting))
        return polished

    def _run_polishes(self, tasks: list[Polish]) -> dict[int, dict]:
        results: dict[int, dict] = {}
        self.executor.run(tasks, lambda row: results.__setitem__(row["start_id"], row))
        return results

    def _searched(self, end: SearchEnd, point: EndPoint, basin: Basin, outcome: str) -> dict:
        """A searched start's own columns: its outcome, basin, search figures and end point."""
        reached = end.grasp
        assert end.forces is not None and reached is not None
        grasp = Grasp(reached.palm_rotation, reached.palm_position, reached.joint_angles)
        columns = grasp_columns(grasp, self.joint_names, self.fingers, reached.contacts, reached.normals)
        return {
            "outcome": outcome,
            "basin": basin.basin_id,
            "polished_start": basin.polished_start,
            "search_status": end.status,
            "search_iterations": end.iterations,
            "search_seconds": end.seconds,
            "search_attempts": end.attempts,
            "search_Q": end.forces.Q,
            "search_value": end.forces.value,
            "search_closes": end.forces.closes,
            "search_descriptor": [float(v) for v in point.descriptor],
            **{f"search_{k}": v for k, v in columns.items()},
        }

    def _joined(self, start: Start, end: SearchEnd, point: EndPoint, basin: Basin) -> dict:
        """A start whose end point joined a basin another start's polish stands for: its own Q and end point."""
        assert end.forces is not None
        message = f"basin {basin.basin_id}, polished from start {basin.polished_start}"
        row = failed_row(start.start_id, start.orientation, start.position_name, "same-basin", end.seconds, message)
        return {
            **row,
            "iterations": end.iterations,
            "Q": end.forces.Q,
            **self._searched(end, point, basin, "same-basin"),
        }

    def _unsearched(self, start: Start, end: SearchEnd) -> dict:
        """A start whose search did not converge: why (far from the surface, in collision, not finite)."""
        message = f"search: {end.message}"
        row = failed_row(start.start_id, start.orientation, start.position_name, end.status, end.seconds, message)
        figures = {"search_status": end.status, "search_attempts": end.attempts}
        return {**row, "iterations": end.iterations, "outcome": "search-failed", **figures}


def known_basins(rows: list[dict]) -> list[Basin]:
    """The basins of a resumed sweep's rows, from their basin ids, descriptors and force-problem values."""
    basins: dict[int, Basin] = {}
    for row in sorted(rows, key=lambda r: r["start_id"]):
        basin_id = row.get("basin")
        if basin_id is None or (isinstance(basin_id, float) and np.isnan(basin_id)):
            continue
        described = np.asarray(row["search_descriptor"], float)
        point = EndPoint(int(row["start_id"]), described, float(row["search_Q"]), float(row["search_value"]))
        basin = basins.setdefault(int(basin_id), Basin(int(basin_id), []))
        basin.members.append(point)
        if row.get("outcome") == "polished" and (basin.polished_start is None or row.get("verified")):
            basin.polished_start, basin.verified = int(row["start_id"]), bool(row.get("verified"))
    return [basins[k] for k in sorted(basins)]
