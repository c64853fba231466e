#!/usr/bin/env python3
"""Checks the layering of docs/architecture.md: which folder may include which, which
third-party headers each folder may use, and which library targets each library may link.

Usage: scripts/check_layering.py [--root DIR]
Exit 0 when every edge is allowed; 1 with one line per forbidden edge (file:line: what);
2 on bad usage. Run by ctest (tests/layering/).

Rules are by folder, most specific first: a file belongs to the longest folder prefix
listed in LAYERS. Each folder may include its own headers and those of the folders it
lists (quoted includes, written from the repository root: "sched/core/types.hpp").
tests/ and bench/ may use everything; apps/ everything but third-party headers it has
no business with.
"""
import argparse
import os
import re
import sys

SCHED_CORE = ["common", "sched/core"]
SCHED_ALL = ["common", "sched"]
RENDER_INTEGRATOR = ["common", "render/scene", "render/partition"]
RENDER_ENGINES = ["render/integrator", "render/embree", "render/vulkan"]
# folder -> folders (prefixes) its quoted includes may name, besides itself
LAYERS = {
    "common": [],
    "sched/core": ["common"],
    "sched/timeline": SCHED_CORE,
    "sched/sdc": SCHED_CORE + ["sched/timeline"],
    "sched/io": SCHED_CORE + ["sched/timeline"],
    # policy/ holds the Scheduler seam, the Placer and the factory that names every policy
    "sched/policy": SCHED_CORE + ["sched/timeline", "sched/sdc", "sched/policy"],
    "sched/runtime": SCHED_CORE + ["sched/timeline", "sched/policy/scheduler.hpp"],
    "workload": SCHED_ALL,
    "sim": SCHED_ALL + ["workload"],
    # render/: the scene, then its blocks, then what a ray does between hits (integrator),
    # the two traversal engines, where blocks and rays live (store), the seam choosing an
    # engine per device (accel), and the engine driving it all
    "render/scene": ["common"],
    "render/image": ["common"],
    "render/partition": ["common", "render/scene"],
    "render/reference": ["common", "render/scene"],
    "render/integrator": RENDER_INTEGRATOR,
    "render/embree": RENDER_INTEGRATOR + ["render/integrator"],
    "render/vulkan": ["common", "render/scene"],
    "render/store": RENDER_INTEGRATOR + RENDER_ENGINES + ["sched/core/types.hpp"],
    "render/accel": RENDER_INTEGRATOR + RENDER_ENGINES + ["render/store", "sched/core/types.hpp"],
    "render/engine": SCHED_ALL + ["workload", "render"],
    # the distributed render: the engine's seam (render/engine/cluster.hpp) over MPI
    "render/mpi": SCHED_ALL + ["workload", "render"],
    "apps": SCHED_ALL + ["workload", "sim", "render", "apps"],
    # `rayline report` reads a run's files: it needs none of the engines
    "apps/report": ["common"],
    "tests": None,  # anything
    "bench": None,
}

# third-party header prefix -> folders (prefixes) that may include it; a trailing
# ".cpp" restricts it to source files (no header may drag it in). The first prefix that
# matches applies, so a narrower one comes before a wider one.
THIRD_PARTY = {
    "simgrid/": ["sim/sg_platform.cpp", "sim/sg_platform_internal.hpp"],
    "mpi.h": ["render/mpi/comm.cpp"],
    "embree3/": ["render/embree", "render/vulkan", "render/reference"],
    "vulkan/": ["render/vulkan"],
    "CLI/": ["apps/main.cpp", "apps/cli_reference.cpp"],
    # the JSON fields helper declares its types with the forward header (no parser)
    "nlohmann/json_fwd.hpp": ["common/json_fields.hpp"],
    "nlohmann/": ["common/json_fields.cpp", "sched/io/*.cpp", "workload/*.cpp", "sim/*.cpp", "render/*.cpp",
                  "apps/*.cpp"],
    "Eigen/": ["sched/core/nnls.cpp", "workload/ray_flow_expectation.cpp"],
    "glpk.h": ["workload/compute_bound.cpp"],
    "Imf": ["render/image"],
    "png.h": ["render/image"],
    "assimp/": ["render/scene"],
    "tbb/": ["render/accel", "render/engine", "render/reference"],
    "oneapi/": ["render/accel", "render/engine", "render/reference"],
}

# library target -> its folder (the folder's layer rules apply to what it links)
TARGETS = {
    "rayline_common": "common",
    "rayline_sched": "sched/policy",  # the whole core; links nothing of ours but common
    "rayline_workload": "workload",
    "rayline_sim": "sim",
    "rayline_scene": "render/scene",
    "rayline_image": "render/image",
    "rayline_partition": "render/partition",
    "rayline_reference": "render/reference",
    "rayline_integrator": "render/integrator",
    "rayline_embree": "render/embree",
    "rayline_vulkan": "render/vulkan",
    "rayline_store": "render/store",
    "rayline_mpi": "render/mpi",
    "rayline_accel": "render/accel",
    "rayline_render": "render/engine",
    "rayline_report": "apps/report",
}
TARGET_FOLDER_OF_LINK = {  # what a linked target stands for, as an include prefix
    "rayline_common": "common", "rayline_sched": "sched", "rayline_workload": "workload",
    "rayline_sim": "sim", "rayline_scene": "render/scene", "rayline_image": "render/image",
    "rayline_partition": "render/partition", "rayline_reference": "render/reference",
    "rayline_integrator": "render/integrator", "rayline_embree": "render/embree", "rayline_vulkan": "render/vulkan",
    "rayline_store": "render/store",
    "rayline_mpi": "render/mpi", "rayline_accel": "render/accel", "rayline_render": "render/engine",
    "rayline_report": "apps/report",
}

SOURCE_EXT = (".cpp", ".hpp", ".h")
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^">]+)[">]')


def layer_of(rel):
    best = None
    for folder in LAYERS:
        if rel == folder or rel.startswith(folder + "/"):
            if best is None or len(folder) > len(best):
                best = folder
    return best


def under(path, prefix):
    """path lies under prefix (a folder, a file, or 'folder/*.ext')."""
    if "*" in prefix:
        folder, pattern = prefix.split("*", 1)
        return path.startswith(folder) and path.endswith(pattern)
    return path == prefix or path.startswith(prefix.rstrip("/") + "/")


def check_sources(root):
    errors = []
    for top in sorted({folder.split("/", 1)[0] for folder in LAYERS}):
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, top)):
            dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
            for name in sorted(filenames):
                if not name.endswith(SOURCE_EXT):
                    continue
                rel = os.path.relpath(os.path.join(dirpath, name), root).replace(os.sep, "/")
                errors += check_file(root, rel)
    return errors


def check_file(root, rel):
    layer = layer_of(rel)
    if layer is None:
        return [f"{rel}:1: in no layer of docs/architecture.md (add its folder to LAYERS in {os.path.basename(__file__)})"]
    allowed = LAYERS[layer]
    errors = []
    with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
        for lineno, line in enumerate(f, 1):
            m = INCLUDE.match(line)
            if not m:
                continue
            kind, target = m.groups()
            if kind == '"':
                top = target.split("/", 1)[0]
                if "/" not in target or top not in ("common", "sched", "workload", "sim", "render", "apps"):
                    continue  # a local header of tests/ or bench/, or a generated one
                if allowed is None or under(target, layer):
                    continue
                if not any(under(target, p) for p in allowed):
                    errors.append(f"{rel}:{lineno}: {layer}/ may not include \"{target}\" "
                                  f"(allowed: {', '.join(allowed) or 'nothing outside ' + layer})")
            else:
                for prefix, users in THIRD_PARTY.items():
                    if target.startswith(prefix):
                        if layer in ("tests", "bench"):
                            break
                        if not any(under(rel, u) for u in users):
                            errors.append(f"{rel}:{lineno}: <{target}> is allowed only in {', '.join(users)}")
                        break
    return errors


LINK = re.compile(r"target_link_libraries\(\s*(\S+)([^)]*)\)", re.S)


def check_links(root):
    errors = []
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith(".") and d not in ("build", "assets"))
        if "CMakeLists.txt" not in filenames:
            continue
        rel_cmake = os.path.relpath(os.path.join(dirpath, "CMakeLists.txt"), root)
        with open(os.path.join(dirpath, "CMakeLists.txt"), encoding="utf-8") as f:
            text = f.read()
        for m in LINK.finditer(text):
            target, rest = m.group(1), m.group(2)
            if target not in TARGETS:
                continue
            allowed = LAYERS[TARGETS[target]]
            for dep in re.findall(r"\brayline_\w+", rest):
                dep_folder = TARGET_FOLDER_OF_LINK.get(dep)
                if dep_folder is None:
                    continue
                if under(dep_folder, TARGETS[target]) or any(under(dep_folder, p) or under(p, dep_folder)
                                                              for p in allowed):
                    continue
                line = text[: m.start()].count("\n") + 1
                errors.append(f"{rel_cmake}:{line}: {target} ({TARGETS[target]}/) may not link {dep} ({dep_folder}/)")
    return errors


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."),
                    help="repository root (default: this script's repository)")
    args = ap.parse_args()
    root = os.path.abspath(args.root)
    if not os.path.isdir(os.path.join(root, "sched")):
        print(f"check_layering: {root}: not a Rayline source tree (no sched/)", file=sys.stderr)
        return 2
    errors = check_sources(root) + check_links(root)
    for e in errors:
        print(e)
    if errors:
        print(f"check_layering: {len(errors)} forbidden edge(s); the rules are in docs/architecture.md",
              file=sys.stderr)
        return 1
    print("check_layering: every include and link follows docs/architecture.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
