#pragma once
// One fixed step of the simulation: the Model's pipeline of stages run over the State, each
// timed and counted into a StepReport. step() never allocates: every buffer it needs lives
// in a Scratch sized by make_scratch(); overflow is reported as a flag, and grow_scratch()
// (between steps) makes room.
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "ffd/model.h"
#include "ffd/state.h"

namespace ffd {

class WorkerPool;

// Work counters of one stage in one step. A counter a stage has no use for stays zero.
struct StageCounters {
  std::uint32_t boxes_updated = 0;      // FFD AABBs recomputed from the lattice (eq. 2)
  std::uint32_t hash_entries = 0;       // (box, grid cell) entries the broad phase's grids held
  std::uint32_t inter_pairs_tested = 0; // box pairs of different objects given node tests
  std::uint32_t self_pairs_tested = 0;  // box pairs of one object given node tests
  std::uint32_t node_tests = 0;         // node-in-box or node-below-plane tests
  std::uint32_t inter_contacts = 0;     // nodes found inside a box of another object
  std::uint32_t self_contacts = 0;      // nodes found inside a non-adjacent box of the same object
  std::uint32_t plane_contacts = 0;     // boxes found below a static plane
  std::uint32_t probe_contacts = 0;     // probe nodes in a box, or box nodes in the probe sphere
  std::uint32_t objects_asleep = 0;     // objects asleep after the Sleep stage ("sleeping")
};

enum class ContactKind : std::uint8_t { Inter, Self, Plane, Probe };

// One contact found and answered this step, for display: where, along which normal, how deep.
struct Contact {
  Vec3 point = Vec3::Zero();   // m, the node found inside
  Vec3 normal = Vec3::Zero();  // unit, direction the node was pushed out along
  double depth = 0.0;          // m, r of eq. 7
  ContactKind kind = ContactKind::Inter;
};

inline constexpr std::size_t kStageCount = static_cast<std::size_t>(Stage::Count);

struct StepReport {
  std::uint64_t step = 0;                          // index of the step this report describes
  std::array<std::int64_t, kStageCount> stage_ns{};  // wall time per stage, ns (-1: not run)
  std::array<StageCounters, kStageCount> counters{};
  std::int64_t total_ns = 0;
  double max_box_penetration_m = 0.0;  // deepest node-in-box or node-below-plane depth r
  bool finite = true;                  // every x and v finite after the step
  bool hash_overflow = false;          // broad phase ran out of room for grid entries or pairs; grow_scratch() fixes it
  std::uint32_t contacts_recorded = 0; // Scratch::contacts[0 .. contacts_recorded) hold this step's
  std::uint32_t contacts_dropped = 0;  // contacts beyond Scratch::contacts' capacity (not recorded)
  std::uint32_t constraints = 0;       // response "solver": contact constraints solved this step
  bool constraints_overflow = false;   // some were dropped for want of room; grow_scratch() fixes it
};

struct StepMemory;  // every stage's working memory (runtime/src/step_memory.h)

// Working memory of step(): derived per step, never part of the State; made by
// make_scratch() for one Model, with room for everything a step needs.
class Scratch {
 public:
  Scratch();  // no memory: make_scratch() gives a usable one
  explicit Scratch(std::unique_ptr<StepMemory> memory);
  Scratch(Scratch&&) noexcept;
  Scratch& operator=(Scratch&&) noexcept;
  ~Scratch();

  // The contacts the last step found and answered, for display (at most kContactCapacity;
  // StepReport::contacts_dropped counts the rest).
  std::span<const Contact> contacts() const;
  // The 9 nodes of every box of the accuracy level's box set (8 corners, then the centre of
  // mass) as the last step, or update_all_boxes(), left them; a box a response made stale
  // since is recomputed only when next needed.
  std::span<const std::array<Vec3, 9>> box_nodes() const;

  // The stages' memories, for the runtime and its tests.
  StepMemory& memory() { return *memory_; }
  const StepMemory& memory() const { return *memory_; }

 private:
  std::unique_ptr<StepMemory> memory_;
};

inline constexpr std::size_t kContactCapacity = 4096;

Scratch make_scratch(const Model& model);
// The step spreads its work over `pool` (which must outlive the Scratch's use), with room
// for each of its threads. Call before stepping, not inside a step.
void attach_pool(const Model& model, Scratch& scratch, WorkerPool& pool);
// Makes room for what the last step reported it lacked (call between steps).
void grow_scratch(const Model& model, Scratch& scratch, const StepReport& last);

// Advances `state` by one step of model.settings.dt and fills `report`.
void step(const Model& model, State& state, Scratch& scratch, StepReport& report);

// The SIMD target the step's kernels run on ("AVX3", "AVX2", "SSE4", "SCALAR", ...): the best
// this CPU has, chosen at run time. Every target gives the same bits.
const char* simd_target_name();

// The springs alone, for the bench's cost of one spring projection: `sweeps` XPBD sweeps of
// every awake mass-spring object's springs from `state` (a copy is changed, not it), on this
// thread, without the prediction, volumes, shapes or velocities. Returns the seconds.
double time_spring_sweeps(const Model& model, const State& state, int sweeps);

// Recomputes the nodes of every box of the State's accuracy level from the lattice (eq. 2),
// for tools that need the boxes of a State (frames, tests).
void update_all_boxes(const Model& model, const State& state, Scratch& scratch);

}  // namespace ffd
