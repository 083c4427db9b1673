#include <cstring>

#include "ffd/model.h"
#include "ffd/spec.h"

namespace ffd {

const char* effect_name(Effect e) {
  switch (e) {
    case Effect::Gravity: return "gravity";
    case Effect::Planes: return "planes";
    case Effect::InterCollision: return "inter_collision";
    case Effect::SelfCollision: return "self_collision";
    case Effect::Friction: return "friction";
    case Effect::Probe: return "probe";
    case Effect::Grab: return "grab";
    case Effect::Sleeping: return "sleeping";
  }
  return "?";
}

bool effect_from_name(const std::string& name, Effect& out) {
  for (Effect e : kAllEffects) {
    if (name == effect_name(e)) {
      out = e;
      return true;
    }
  }
  return false;
}

const char* accuracy_name(Accuracy a) {
  switch (a) {
    case Accuracy::GridCells: return "grid cells";
    case Accuracy::BoundaryNodes: return "FFD AABB, 8 nodes";
    case Accuracy::CentreOfMass: return "FFD AABB + centre of mass";
    case Accuracy::SampleNodes: return "FFD AABB, 27 surface nodes";
    case Accuracy::SubBoxes: return "FFD sub-boxes";
    case Accuracy::Exact: return "exact surfaces";
  }
  return "?";
}

const char* response_name(ContactResponse r) {
  switch (r) {
    case ContactResponse::Paper: return "paper";
    case ContactResponse::Solver: return "solver";
  }
  return "?";
}

bool response_from_name(const std::string& name, ContactResponse& out) {
  for (ContactResponse r : {ContactResponse::Paper, ContactResponse::Solver})
    if (name == response_name(r)) {
      out = r;
      return true;
    }
  return false;
}

const char* stage_name(Stage s) {
  switch (s) {
    case Stage::Gravity: return "gravity";
    case Stage::Dynamics: return "dynamics";
    case Stage::BoxUpdate: return "box_update";
    case Stage::BroadPhase: return "broad_phase";
    case Stage::NarrowPhase: return "narrow_phase";
    case Stage::Planes: return "planes";
    case Stage::Interaction: return "interaction";
    case Stage::ContactSolve: return "contact_solve";
    case Stage::Sleep: return "sleep";
    case Stage::Count: break;
  }
  return "?";
}

}  // namespace ffd
