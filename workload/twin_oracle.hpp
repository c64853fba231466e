// Where the rays of a render's twin go (docs/validation.md): the ray-outcome oracle, the one
// part of the workload the twin does not share with the renderer (workload/render_twin.hpp).
//   * replay — the ray log itself (workload/ray_log.hpp): every ray does exactly what it did
//     in the recorded render, for any batching and schedule;
//   * markov — statistics of the log: where camera rays enter, per image tile (8 x 8), and
//     per (cell, ray kind, bounce) how often a visit handed on which rays to which cells,
//     sampled per ray. It forgets which ray did what, so it also describes the same scene at
//     another resolution, spp or seed.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "workload/ray_log.hpp"

namespace rayline {

struct TwinRay {
  std::uint32_t visit = 0;  // replay: the log's visit
  std::uint32_t cell = 0;
  std::uint8_t kind = 0;    // 0 path, 1 shadow
  std::uint8_t bounce = 0;  // surface hits so far along its path
};

class TwinOracle {
 public:
  virtual ~TwinOracle() = default;
  virtual std::uint64_t camera_rays() const = 0;
  virtual std::uint32_t spp() const = 0;
  virtual std::uint32_t width() const = 0;
  virtual std::uint32_t height() const = 0;
  // Camera ray i (pixel i % pixels, sample i / pixels): its first ray, or false when it
  // misses every cell.
  virtual bool entry(std::uint64_t i, TwinRay& r) = 0;
  // The rays `r` handed on after its visit to r.cell, appended to `out` (none: it ended there).
  virtual void visit(const TwinRay& r, std::vector<TwinRay>& out) = 0;
};

class ReplayOracle final : public TwinOracle {
 public:
  explicit ReplayOracle(std::shared_ptr<const RayLog> log) : log_(std::move(log)) {}
  std::uint64_t camera_rays() const override { return log_->camera_rays(); }
  std::uint32_t spp() const override { return log_->spp; }
  std::uint32_t width() const override { return log_->width; }
  std::uint32_t height() const override { return log_->height; }
  bool entry(std::uint64_t i, TwinRay& r) override;
  void visit(const TwinRay& r, std::vector<TwinRay>& out) override;

 private:
  std::shared_ptr<const RayLog> log_;
};

// The Markov model of a ray log, for a render of width x height x spp (the log's own, or
// another) with its own random stream.
class MarkovOracle final : public TwinOracle {
 public:
  MarkovOracle(const RayLog& log, std::uint32_t width, std::uint32_t height, std::uint32_t spp, std::uint64_t seed);
  std::uint64_t camera_rays() const override { return std::uint64_t(width_) * height_ * spp_; }
  std::uint32_t spp() const override { return spp_; }
  std::uint32_t width() const override { return width_; }
  std::uint32_t height() const override { return height_; }
  bool entry(std::uint64_t i, TwinRay& r) override;
  void visit(const TwinRay& r, std::vector<TwinRay>& out) override;
  std::size_t states() const { return states_.size(); }

  static constexpr std::uint32_t kTiles = 8;  // entry statistics per tile of a kTiles x kTiles grid

 private:
  // An outcome: the rays a visit handed on, as (kind, bounce) and cell each.
  struct Outcome {
    std::uint8_t n = 0;
    std::uint8_t kind[2] = {0, 0}, bounce[2] = {0, 0};
    std::uint32_t cell[2] = {0, 0};
  };
  struct State {
    std::vector<Outcome> outcomes;
    std::vector<std::uint64_t> cumulative;  // counts summed in outcome order
  };
  static std::uint64_t key(std::uint32_t cell, std::uint8_t kind, std::uint8_t bounce) {
    return (std::uint64_t(cell) << 9) | (std::uint64_t(bounce) << 1) | kind;
  }
  std::uint64_t next();  // splitmix64
  std::uint64_t below(std::uint64_t n) { return n ? next() % n : 0; }

  std::uint32_t width_, height_, spp_, cells_;
  std::uint64_t state_;
  std::vector<std::vector<std::uint64_t>> entry_;  // per tile: cumulative counts over [miss, cell 0..]
  std::unordered_map<std::uint64_t, State> states_;
};

}  // namespace rayline
