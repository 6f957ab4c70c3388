"""Large-mesh benchmark: `vprobot plan` on a CAD-density part, time, memory and coverage.

The part is the bundled default motor, Loop-subdivided (trimesh) four times to 1.53 M triangles,
as a CAD export of a real part would be tessellated, and twice (95.8 k triangles) as the same
part at a modest density. Each is planned by the real command in a child process with a cold
ground-truth cache: wall time and peak memory (the child's maximum resident set) of
`vprobot plan --mesh PART` until the coverage goal, then B_SCP with a fixed number of views on a
few seeds, whose mean coverage is compared between the two densities (a fixed view count keeps
the comparison to the views' quality, not to when the goal happened to be crossed). Plans on two
meshes differ in their views as well; the same views are compared by replaying the dense part's
plans on the modest part (`vprobot render --plan` does the same replay).
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import trimesh
from tqdm import tqdm

from vprobot.compute.processes import child_environment
from vprobot.config import Config
from vprobot.files.paths import CACHE_ENV_VAR, DEFAULT_MOTOR

DENSITIES = {"dense": 4, "modest": 2}
"""Loop subdivisions of the default motor per part density."""
FIXED_VIEWS = 4


def subdivided_motor(iterations: int) -> trimesh.Trimesh:
    """The default motor, duplicate vertices merged, Loop-subdivided `iterations` times."""
    mesh = trimesh.load(DEFAULT_MOTOR, process=False)
    assert isinstance(mesh, trimesh.Trimesh)  # an STL loads as one mesh
    mesh.merge_vertices()
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.remove_unreferenced_vertices()
    return mesh.subdivide_loop(iterations=iterations)


_CHILD = ("import resource, sys\n"
          "from vprobot.cli import main\n"
          "code = main(sys.argv[1:])\n"
          "print('peak_kib', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)\n"
          "sys.exit(code)\n")
"""`vprobot plan` in a child (that ends with this process) that reports its own peak resident
set (KiB on Linux)."""


def _plan(mesh: Path, out: Path, cache: Path, options: Sequence[str] = ()) -> dict[str, Any]:
    """Run `vprobot plan` in a child; its wall time, peak memory and plan JSON."""
    start = time.perf_counter()
    child = subprocess.run([sys.executable, "-c", _CHILD, "plan", "--mesh", str(mesh), "--out",
                            str(out), *options], check=True, capture_output=True, text=True,
                           env={**child_environment(), CACHE_ENV_VAR: str(cache)})
    wall = time.perf_counter() - start
    peak_kib = int(child.stderr.rsplit("peak_kib", 1)[1].split()[0])
    document = json.loads(out.read_text())
    return {"wall_s": wall, "peak_gib": peak_kib / 1024**2,
            "coverage_pct": 100.0 * document["coverage"], "views": len(document["views"]),
            "object": document["object"]}


def run_large_mesh_benchmark(config: Config, plan_options: Sequence[str] = (),
                             seeds: Sequence[int] = (0, 1, 2),
                             progress: bool = True) -> dict[str, Any]:
    """Plan the dense and the modest part; see the module docstring.

    Args:
        config: The configuration the plans are made with (for the replays).
        plan_options: Options every `vprobot plan` gets (e.g. `--robot panda`).
        seeds: Episode seeds of the fixed-view plans.
        progress: Show a progress bar.

    Returns:
        Per density (`dense_*`, `modest_*`): `faces`, `plan_s` and `plan_peak_gib` (cold
        cache, until the goal), `goal_coverage_pct`, `goal_views`, `views4_coverage_pct` (mean
        over `seeds` of B_SCP with 4 views); `dense_simplified_faces`,
        `dense_max_deviation_mm` / `dense_mean_deviation_mm` (simplified copy to original);
        `views4_coverage_gap_pp` (dense minus modest, each with its own plans);
        `dense_plans_on_modest_pct` (the dense part's 4-view plans replayed on the modest part)
        and `same_views_gap_pp_mean` / `_max_abs` (dense claimed minus replayed).
    """
    results: dict[str, Any] = {"seeds": list(seeds)}
    steps = len(DENSITIES) * (1 + len(seeds))
    with tempfile.TemporaryDirectory() as folder, tqdm(total=steps, desc="large mesh",
                                                       disable=not progress) as bar:
        root = Path(folder)
        for name, iterations in DENSITIES.items():
            mesh_path = root / f"motor_{name}.stl"
            mesh = subdivided_motor(iterations)
            mesh.export(mesh_path)
            results[f"{name}_faces"] = len(mesh.faces)
            del mesh
            cache = root / f"cache_{name}"
            goal = _plan(mesh_path, root / f"{name}_goal.json", cache, plan_options)
            bar.update()
            results[f"{name}_plan_s"] = goal["wall_s"]
            results[f"{name}_plan_peak_gib"] = goal["peak_gib"]
            results[f"{name}_goal_coverage_pct"] = goal["coverage_pct"]
            results[f"{name}_goal_views"] = goal["views"]
            simplification = goal["object"].get("simplification")
            if simplification is not None:
                results[f"{name}_simplified_faces"] = simplification["faces_after"]
                results[f"{name}_max_deviation_mm"] = 1e3 * simplification["max_deviation_m"]
                results[f"{name}_mean_deviation_mm"] = 1e3 * simplification["mean_deviation_m"]
            coverages = []
            for seed in seeds:
                fixed = _plan(mesh_path, root / f"{name}_{seed}.json", cache,
                              (*plan_options, "--views", str(FIXED_VIEWS), "--seed", str(seed)))
                coverages.append(fixed["coverage_pct"])
                bar.update()
            results[f"{name}_views4_coverage_pct"] = statistics.fmean(coverages)
            results[f"{name}_views4_per_seed_pct"] = coverages
        # The same views on both densities: the dense part's plans replayed on the modest part.
        replayed = [_replayed_on(config, root / f"dense_{seed}.json", root / "motor_modest.stl")
                    for seed in seeds]
        gaps = [dense - modest for dense, modest in
                zip(results["dense_views4_per_seed_pct"], replayed, strict=True)]
    results["dense_plans_on_modest_pct"] = replayed
    results["same_views_gap_pp_mean"] = statistics.fmean(gaps)
    results["same_views_gap_pp_max_abs"] = max(abs(gap) for gap in gaps)
    results["views4_coverage_gap_pp"] = (results["dense_views4_coverage_pct"]
                                         - results["modest_views4_coverage_pct"])
    return results


def _replayed_on(config: Config, plan: Path, mesh: Path) -> float:
    """Coverage (%) of a plan's views replayed on another mesh of the same part."""
    # Imported here: the renderer's package (OpenGL, imageio) only for this one benchmark.
    from vprobot.render import episode_from_plan

    document = json.loads(plan.read_text())
    document["object"]["mesh"] = str(mesh)
    document["object"].pop("simplification", None)
    swapped = plan.with_name(f"{plan.stem}_on_{mesh.stem}.json")
    swapped.write_text(json.dumps(document))
    _, record = episode_from_plan(config, swapped)
    return 100.0 * record.coverage
