#!/usr/bin/python3
"""Writes platforms/*.json: the paper's cluster (Son & Yoon 2017, Sec. 6, Fig. 7), the
subsets of its scaling study (Fig. 8), and a multi-GPU workstation. Every number is an
assumption documented in platforms/README.md; edit here, then run this script."""
import json, os

RAY = 64  # bytes per ray record (docs/architecture.md: 32-64 B)

def rays(mrays_per_s):  # throughput of a RayQueue / ShadowRayQueue in bytes/s
    return f"{mrays_per_s * RAY:g}MB/s"

def cpu_timing(mrays):
    return {
        "RayIntersect": {"setup": "5us", "rate": {"RayQueue": rays(mrays)}},
        "ShadowIntersect": {"setup": "5us", "rate": {"ShadowRayQueue": rays(mrays * 1.4)}},
        "GenerateRays": {"setup": "5us", "rate": {"Generic": "2GB/s"}},
        "Shade": {"setup": "5us", "rate": {"RayQueue": rays(mrays * 4)}},
        "Accumulate": {"setup": "5us", "rate": {"Framebuffer": "4GB/s"}},
        "AdditiveCompose": {"setup": "5us", "rate": {"Framebuffer": "4GB/s"}},
        "Compute": {"setup": "5us", "rate": {"Generic": "100MB/s"}},
    }

def gpu_timing(mrays):
    t = {
        "RayIntersect": {"setup": "50us", "rate": {"RayQueue": rays(mrays)}},
        "ShadowIntersect": {"setup": "50us", "rate": {"ShadowRayQueue": rays(mrays * 1.4)}},
        "GenerateRays": {"setup": "50us", "rate": {"Generic": "20GB/s"}},
        "Shade": {"setup": "50us", "rate": {"RayQueue": rays(mrays * 4)}},
        "Accumulate": {"setup": "50us", "rate": {"Framebuffer": "40GB/s"}},
        "AdditiveCompose": {"setup": "50us", "rate": {"Framebuffer": "40GB/s"}},
        "Compute": {"setup": "50us", "rate": {"Generic": "1GB/s"}},
    }
    return t

def node_type(desc, threads, cpu_mrays, gpu_mrays, gpu_mem):
    return {
        "description": desc,
        "memory": [
            {"name": "disk", "kind": "disk", "capacity": "1TB"},
            {"name": "ram", "kind": "host", "capacity": "8GiB"},
            {"name": "gpu0mem", "kind": "gpu", "capacity": gpu_mem},
        ],
        "compute": [
            {"name": "cpu", "kind": "cpu", "count": threads, "memory": "ram", "timing": cpu_timing(cpu_mrays)},
            {"name": "gpu0", "kind": "gpu", "memory": "gpu0mem", "timing": gpu_timing(gpu_mrays)},
        ],
        "channels": [
            {"name": "sata", "kind": "sata", "between": ["disk", "ram"], "duplex": "half", "latency": "10ms", "bandwidth": "150MB/s"},
            {"name": "pcie0", "kind": "pcie", "between": ["ram", "gpu0mem"], "duplex": "full", "latency": "10us", "bandwidth": "12GB/s"},
        ],
    }

TYPES = {
    "A": node_type("i7-4770 (8 hw threads) + GTX Titan", 8, 0.5, 10, "6GiB"),
    "B": node_type("i7-4790 (8 hw threads) + GTX Titan", 8, 0.55, 10, "6GiB"),
    "C": node_type("E5-2690 (16 hw threads) + GTX Titan", 16, 0.45, 10, "6GiB"),
    "D": node_type("E5-2690 (16 hw threads) + GTX Titan X", 16, 0.45, 14, "12GiB"),
    "R": node_type("i7-3770 (4 hw threads) + GTX 980, commodity desktop", 4, 0.45, 9, "4GiB"),
}
NIC = {"A": "1Gb/s", "B": "100Mb/s", "C": "100Mb/s", "D": "100Mb/s", "R": "100Mb/s"}
ALL = [("A0", "A"), ("A1", "A"), ("A2", "A"), ("A3", "A"), ("B", "B"), ("C", "C"), ("D", "D"), ("R", "R")]

def cluster(name, nodes, desc):
    used = sorted({t for _, t in nodes})
    p = {
        "name": name,
        "description": desc,
        "node_types": {t: TYPES[t] for t in used},
        "nodes": [{"name": n, "type": t} for n, t in nodes],
    }
    if len(nodes) > 1:
        p["networks"] = [{
            "name": "lan", "kind": "lan", "latency": "100us", "duplex": "full",
            "members": [{"node": n, "memory": "ram", "bandwidth": NIC[t]} for n, t in nodes],
        }]
    return p

def write(fname, p):
    path = os.path.join(os.path.dirname(__file__), "..", "platforms", fname)
    with open(path + ".tmp", "w") as f:
        json.dump(p, f, indent=2)
        f.write("\n")
    os.replace(path + ".tmp", path)

write("paper-cluster.json", cluster("paper-cluster", ALL,
      "Son & Yoon 2017, Sec. 6: 4xA + B + C + D + R, 84 compute devices, 24 memory devices"))
for label, n in [("A", 1), ("2A", 2), ("3A", 3), ("4A", 4), ("4A+B", 5), ("4A+B+C", 6), ("4A+B+C+D", 7)]:
    write(f"paper-{label}.json", cluster(f"paper-{label}", ALL[:n], f"Fig. 8 scaling subset {label} of the paper cluster"))

# Scale studies (docs/performance.md, "Scaling"): N type-A nodes in racks of 32 on a
# backbone. 1 Gb/s NICs, a 10 Gb/s uplink per rack (32 Gb/s of NICs: 3.2:1 oversubscribed),
# and a core as fast as all the uplinks together.
RACK = 32
for n in (64, 256, 1024):
    racks = n // RACK
    p = cluster(f"scale-{n}", [(f"A{i}", "A") for i in range(n)],
                f"{n} type-A nodes (8 hw threads + 1 GPU each) in {racks} racks of {RACK} on a backbone")
    net = p["networks"][0]
    net["bandwidth"] = "1Gb/s"
    net["backbone"] = {"bandwidth": f"{10 * racks}Gb/s", "latency": "5us"}
    net["racks"] = [{"name": f"r{r}", "uplink": "10Gb/s"} for r in range(racks)]
    net["members"] = [{"node": f"A{i}", "rack": f"r{i // RACK}"} for i in range(n)]
    write(f"scale-{n}.json", p)

ws_gpus = 4
ws = {
    "name": "workstation-4gpu",
    "description": "One multi-GPU workstation (Sec. 6.1, last paragraph): 16 hw threads, 4 GPUs, NVMe, no network",
    "node_types": {"W": {
        "description": "16 hw threads, 4 GPUs with 24 GiB each, NVMe SSD, 64 GiB RAM",
        "memory": [{"name": "disk", "kind": "disk", "capacity": "2TB"},
                   {"name": "ram", "kind": "host", "capacity": "64GiB"}] +
                  [{"name": f"gpu{i}mem", "kind": "gpu", "capacity": "24GiB"} for i in range(ws_gpus)],
        "compute": [{"name": "cpu", "kind": "cpu", "count": 16, "memory": "ram", "timing": cpu_timing(0.8)}] +
                   [{"name": f"gpu{i}", "kind": "gpu", "memory": f"gpu{i}mem", "timing": gpu_timing(40)} for i in range(ws_gpus)],
        "channels": [{"name": "nvme", "kind": "nvme", "between": ["disk", "ram"], "duplex": "half", "latency": "100us", "bandwidth": "2GB/s"}] +
                    [{"name": f"pcie{i}", "kind": "pcie", "between": ["ram", f"gpu{i}mem"], "duplex": "full", "latency": "10us",
                      "bandwidth": "12GB/s", "media": [f"root{i // 2}"]} for i in range(ws_gpus)],
        # Two GPUs behind each CPU root complex: their PCIe transfers contend for it.
        "media": [{"name": f"root{r}", "bandwidth": "16GB/s"} for r in range(ws_gpus // 2)],
    }},
    "nodes": [{"name": "W", "type": "W"}],
}
write("workstation-4gpu.json", ws)
print("wrote platforms/*.json")
