#pragma once
// The "sleeping" effect, after Box2D and Jolt: an object whose centre of mass has stayed
// within sleep_radius for sleep_time is frozen. Without it a resting pile trembles for ever:
// eq. 9 moves whole cells, the springs answer the bend that leaves, and the next step's
// contacts push back (docs/limits.md). Asleep, an object costs no dynamics, holds
// still exactly where it settled, and collides as a static body.
//
// Objects sleep one by one, not in islands of touching objects as in Box2D: in a deep pile
// the trembling never stops everywhere at once (a deep stack of letters as one island never
// slept), but the letters at the bottom settle first and, asleep, stop passing it on to those above. An
// object wakes when an object moving faster than 2 sleep_radius / sleep_time brings its boxes
// within 2 sleep_radius of the sleeper's, when the probe or the grab touches it, or when a
// command changes its physics. Slower motion meets a sleeper as a static body.
#include "ffd/model.h"
#include "ffd/state.h"
#include "boxes.h"

namespace ffd {

inline bool sleeping(const Model& model) { return has(model.settings.effects, Effect::Sleeping); }

// Before the broad phase: the boxes of an object moving (State::moving) reach 2 sleep_radius
// further in the hash, so that it meets, and wakes, a sleeper it is about to touch or has
// just left.
void set_wake_margins(const Model& model, const BoxSet& boxes, const State& state, BoxMemory& memory);

// Wakes `object`. It counts as still, not as moving, so waking alone does not spread: only
// motion of its centre of mass beyond sleep_radius wakes what it touches.
void wake(State& state, Index object);
void wake_all(State& state);

// A pair of objects whose boxes meet this step (from the broad phase, which never pairs two
// sleepers): a moving object wakes a sleeping one.
void meet(State& state, Index object_a, Index object_b);

// The Sleep stage, after all others: each awake object either stays within sleep_radius of
// its rest anchor (one more still step; after sleep_time it falls asleep with v = 0) or
// leaves it (a new anchor where it is now; `moving` if it left fast). Returns how many
// objects are asleep after it.
std::uint32_t update_sleep(const Model& model, State& state);

}  // namespace ffd
