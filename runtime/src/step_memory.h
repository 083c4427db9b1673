#pragma once
// The step's one context: every stage's working memory (Scratch holds one; make_scratch()
// sizes it for a Model). Each stage's part is declared with the stage: boxes.h,
// broad_phase.h, collision.h (the narrow phase and the contact log), dynamics.h,
// contact_solver.h.
#include "collision.h"
#include "contact_solver.h"
#include "dynamics.h"

namespace ffd {

struct StepMemory : CollisionMemory, DynamicsMemory, SolverMemory {};

}  // namespace ffd
