// Test support: small hand-made run folders as `rayline simulate`, `compare` and `render`
// write them, with numbers the report tests check.
#pragma once
#include <filesystem>
#include <fstream>
#include <string>

namespace rayline::testing {

inline void write_text_file(const std::filesystem::path& p, const std::string& text) {
  std::filesystem::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

// metrics.json of a 4-second simulation on two devices and two channel resources.
inline std::string simulate_metrics(const std::string& scheduler = "gmb") {
  return R"({
  "rayline": {"command": "rayline simulate --out x <b>", "version": "0.1.0"},
  "scheduler": ")" + scheduler + R"(", "platform": "tiny", "workload": "ray-stream",
  "simulated_s": 4.0, "rays_per_second": 2500000.0, "rays_per_second_series": [1e6, 3e6, 2e6, 4e6],
  "lan_utilisation_mean": 0.25, "queue_wait_s": {"p50": 0.5, "p95": 2.0}, "stalled": false,
  "devices": [
    {"name": "A.cpu0", "kind": "cpu", "busy_s": 1.0, "setup_s": 0.0, "fetching_s": 2.0, "idle_s": 1.0, "utilisation": 0.25},
    {"name": "A.gpu0", "kind": "gpu", "busy_s": 3.0, "setup_s": 0.5, "fetching_s": 0.5, "idle_s": 0.0, "utilisation": 0.75}],
  "resources": [
    {"resource": "A.sata", "utilisation": 0.5, "bytes": 3e8, "bandwidth_Bps": 1.5e8, "lan": false},
    {"resource": "lan:A->B", "utilisation": 0.125, "bytes": 1e8, "bandwidth_Bps": 1e9, "lan": true}]
}
)";
}

// jobs.csv: waits (actual_start - created) RayIntersect 1 s; Shade 0 s and 3 s; one
// E-job planned and never started; one T-job.
inline std::string simulate_jobs() {
  return "activity,kind,job,type,device_or_channel,block,bytes,planned_start,planned_end,actual_start,actual_end,"
         "state,created\n"
         "0,T,j0,transfer,A.sata:disk->ram,scene0,1000,0,1,0,1.5,done,0\n"
         "1,E,j0,RayIntersect,A.cpu0,,2000,1,2,1.5,2.5,done,0.5\n"
         "2,E,j1,Shade,A.gpu0,,4000,0,1,0,1,done,0\n"
         "3,E,j2,Shade,A.gpu0,,4000,1,3,3,4,done,0\n"
         "4,E,j3,RayIntersect,A.cpu0,,2000,3,4,,,planned,2.5\n";
}

inline void write_simulate_run(const std::filesystem::path& dir, const std::string& scheduler = "gmb") {
  write_text_file(dir / "metrics.json", simulate_metrics(scheduler));
  write_text_file(dir / "jobs.csv", simulate_jobs());
}

// A compare folder: gmb and budge runs, and compare.csv with a quoted cell.
inline void write_compare_run(const std::filesystem::path& dir) {
  write_simulate_run(dir / "gmb", "gmb");
  write_simulate_run(dir / "budge", "budge");
  write_text_file(dir / "compare.csv",
                  "scheduler,status,rays_per_second,steady_rays_shot_per_second,scheduler_parameters\n"
                  "gmb,ok,3000000,1000000,\"gmb{k=2s; a, b}\"\n"
                  "budge,ok,1500000,500000,\"budge2009{x}\"\n");
}

// A client sweep: clients-2 and clients-10 (sorted by count, not by name).
inline void write_sweep_run(const std::filesystem::path& dir) {
  write_simulate_run(dir / "clients-10");
  write_simulate_run(dir / "clients-2");
  write_text_file(dir / "clients-x" / "metrics.json", "not a sweep point: never read");
}

// A render's outputs IMAGE.metrics.json, IMAGE.jobs.csv, IMAGE.png (not a real PNG: the
// report only embeds its bytes).
inline void write_render_run(const std::filesystem::path& dir, const std::string& stem = "render") {
  write_text_file(dir / (stem + ".metrics.json"), R"({
  "rayline": {"command": "rayline render --out render.exr", "version": "0.1.0"},
  "scheduler": "gmb", "platform": "auto", "scene": "scenes/cornell.json", "seconds": 2.0,
  "rays_per_second": 600000.0, "resolution": [64, 48], "spp": 4,
  "devices": [
    {"device": "W.cpu0", "busy_s": 1.0, "setup_s": 0.0, "fetching_idle_s": 0.5, "true_idle_s": 0.5, "utilisation": 0.5}]
}
)");
  write_text_file(dir / (stem + ".jobs.csv"),
                  "activity,kind,job,type,device_or_channel,block,bytes,planned_start,planned_end,actual_start,"
                  "actual_end,state,created\n"
                  "0,T,ri0,transfer,W.disk:disk->ram,scene0,100,0,0.5,0,0.5,done,0\n"
                  "1,T,ri1,transfer,W.disk:disk->ram,scene1,100,0.2,0.8,0.25,1.0,done,0\n"
                  "2,E,ri0,RayIntersect,W.cpu0,,800,0.5,1,0.5,1.0,done,0\n");
  write_text_file(dir / (stem + ".png"), "foobar");
}

}  // namespace rayline::testing
