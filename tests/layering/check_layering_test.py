#!/usr/bin/env python3
"""The layering check passes on the tree and fails, naming the file, on each kind of
forbidden edge planted into a copy of it (scripts/check_layering.py)."""
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", ".."))
SCRIPT = os.path.join(ROOT, "scripts", "check_layering.py")
FOLDERS = ["common", "sched", "workload", "sim", "render", "apps"]

# (file to change, line appended, text the report must contain)
PLANTS = [
    ("sched/core/types.hpp", '#include "sim/simulation.hpp"\n', "sched/core/types.hpp:"),
    ("sched/core/types.hpp", '#include "workload/ray_stream.hpp"\n', "may not include \"workload/ray_stream.hpp\""),
    ("sched/timeline/schedule.hpp", '#include "sched/policy/placer.hpp"\n', "sched/timeline/schedule.hpp:"),
    ("sched/runtime/runtime_loop.cpp", '#include "sched/policy/gmb/gmb_scheduler.hpp"\n', "sched/runtime/runtime_loop.cpp:"),
    ("common/units.cpp", '#include "sched/core/types.hpp"\n', "common/units.cpp:"),
    ("sim/simulation.cpp", '#include "render/engine/renderer.hpp"\n', "sim/simulation.cpp:"),
    ("render/engine/renderer.cpp", '#include "sim/simulation.hpp"\n', "render/engine/renderer.cpp:"),
    ("render/scene/scene.cpp", '#include "sched/core/types.hpp"\n', "render/scene/scene.cpp:"),
    ("sched/policy/placer.cpp", "#include <simgrid/s4u.hpp>\n", "<simgrid/s4u.hpp> is allowed only in"),
    ("sim/simulation.hpp", "#include <simgrid/s4u/Engine.hpp>\n", "sim/simulation.hpp:"),
    ("sched/core/job_pool.hpp", "#include <nlohmann/json.hpp>\n", "sched/core/job_pool.hpp:"),
    ("render/engine/renderer.cpp", "#include <CLI/CLI.hpp>\n", "render/engine/renderer.cpp:"),
    ("sim/sim_executor.cpp", "#include <embree3/rtcore.h>\n", "sim/sim_executor.cpp:"),
    ("sched/CMakeLists.txt", "target_link_libraries(rayline_sched PUBLIC rayline_workload)\n",
     "rayline_sched (sched/policy/) may not link rayline_workload"),
    ("sim/CMakeLists.txt", "target_link_libraries(rayline_sim PRIVATE rayline_render)\n", "may not link rayline_render"),
]


def run(root):
    p = subprocess.run([sys.executable, SCRIPT, "--root", root], capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr


def copy_tree(dst):
    for folder in FOLDERS:
        shutil.copytree(os.path.join(ROOT, folder), os.path.join(dst, folder),
                        ignore=shutil.ignore_patterns("*.ply", "*.png", "*.glb", "*.exr", "assets"))


def main():
    failures = []
    rc, out = run(ROOT)
    if rc != 0:
        failures.append(f"the tree itself fails the check (rc {rc}):\n{out}")
    with tempfile.TemporaryDirectory() as tmp:
        copy_tree(tmp)
        rc, out = run(tmp)
        if rc != 0:
            failures.append(f"an unchanged copy fails the check (rc {rc}):\n{out}")
        for path, line, expect in PLANTS:
            full = os.path.join(tmp, path)
            with open(full, encoding="utf-8") as f:
                before = f.read()
            with open(full, "a", encoding="utf-8") as f:
                f.write(line)
            rc, out = run(tmp)
            if rc != 1 or expect not in out:
                failures.append(f"planting {line.strip()!r} in {path}: rc {rc}, expected 1 and {expect!r} in:\n{out}")
            with open(full, "w", encoding="utf-8") as f:
                f.write(before)
        # a source file in a folder no layer names
        stray = os.path.join(tmp, "sched", "stray.hpp")
        with open(stray, "w", encoding="utf-8") as f:
            f.write("#pragma once\n")
        rc, out = run(tmp)
        if rc != 1 or "sched/stray.hpp:1: in no layer" not in out:
            failures.append(f"a file outside every layer: rc {rc}, expected 1 and a report in:\n{out}")
    for f in failures:
        print("FAIL:", f)
    print(f"{len(PLANTS)} planted edges, {len(failures)} failure(s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
