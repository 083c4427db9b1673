#include "ffd/random_pile.h"

#include "ffd/spec.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace ffd {

namespace {

// The shortest text that reads back as the same double: the scene file holds the numbers
// the generator drew, bit for bit.
std::string number(double value) {
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text, value).ptr;
  std::string out(text, end);
  if (out.find_first_of(".e") == std::string::npos) out += ".0";  // a TOML float, not an integer
  return out;
}

std::string vec3(double x, double y, double z) { return "[" + number(x) + ", " + number(y) + ", " + number(z) + "]"; }

// Uniform draws from the 64-bit Mersenne Twister, whose sequence the C++ standard fixes; the
// standard's distributions are not fixed across libraries, so the mapping is written here.
class Draw {
 public:
  explicit Draw(std::uint64_t seed) : engine_(seed) {}
  double uniform(double low, double high) {  // [low, high)
    const double unit = static_cast<double>(engine_() >> 11) * 0x1.0p-53;
    return low + (high - low) * unit;
  }
  int integer(int low, int high) {  // [low, high]
    const auto span = static_cast<std::uint64_t>(high - low + 1);
    return low + static_cast<int>(engine_() % span);
  }

 private:
  std::mt19937_64 engine_;
};

const char* const kShapes[] = {"ring", "torus", "plate", "bowl", "letter"};

}  // namespace

std::string random_pile_scene(const PileOptions& o) {
  if (o.objects < 1 || o.objects > 64) throw std::invalid_argument("random pile: objects must be in 1..64");
  if (o.min_cells < 1 || o.max_cells < o.min_cells || o.max_cells > 64)
    throw std::invalid_argument("random pile: cells across must satisfy 1 <= min <= max <= 64");
  if (!(o.cell_size > 0.0) || !std::isfinite(o.cell_size)) throw std::invalid_argument("random pile: cell_size must be > 0");
  if (o.iterations < 1 || o.iterations > 100) throw std::invalid_argument("random pile: iterations must be in 1..100");

  Draw draw(o.seed);
  const double largest = o.max_cells * o.cell_size;  // m, the largest size any object can draw
  const double half_width = largest;                 // m, walls at x, z = +-half_width
  std::string objects;
  double top = 0.0;  // m, the column so far: the highest point of the bounding spheres below
  for (int i = 0; i < o.objects; ++i) {
    const std::string shape = kShapes[draw.integer(0, 4)];
    const double size = draw.integer(o.min_cells, o.max_cells) * o.cell_size;  // m across
    const std::string name = shape + "_" + std::to_string(i);
    std::string surface;
    // Thin-walled: each wall a tenth to a quarter of the object across, so the small ones are
    // thinner than a cell and the large ones a few cells thick.
    // Each draw in a statement of its own: the order in which a function's arguments (or an
    // overloaded operator's operands) are evaluated is unspecified, and GCC and clang differ.
    // The order below is the one GCC took when the piles were first drawn.
    if (shape == "ring") {
      const double height = size * draw.uniform(0.2, 0.6);
      const double thickness = size * draw.uniform(0.1, 0.25);
      surface = "shape = \"ring\"\nradius = " + number(0.5 * size) + "\nthickness = " + number(thickness) +
                "\nheight = " + number(height) + "\n";
    } else if (shape == "torus") {
      const double thickness = size * draw.uniform(0.15, 0.35);
      surface = "shape = \"torus\"\nradius = " + number(0.5 * (size - thickness)) + "\nthickness = " + number(thickness) + "\n";
    } else if (shape == "plate") {
      const double thickness = size * draw.uniform(0.04, 0.12);
      const double width = size * draw.uniform(0.5, 1.0);
      surface = "shape = \"box\"\nsize = " + vec3(size, width, thickness) + "\n";
    } else if (shape == "bowl") {
      surface = "shape = \"bowl\"\nradius = " + number(0.5 * size) + "\nthickness = " + number(size * draw.uniform(0.06, 0.15)) + "\n";
    } else {  // a capital letter about `size` high (the em square), extruded a sixth to a third of it
      const char letter = static_cast<char>('A' + draw.integer(0, 25));
      surface = "glyph = { text = \"" + std::string(1, letter) + "\", font = \"" + o.font + "\", em_size = " +
                number(size) + ", depth = " + number(size * draw.uniform(0.15, 0.3)) +
                ", sample_spacing = " + number(size / 60.0) + " }\n";
    }
    // Every shape fits in a cube `size` across centred on its origin (the bowl's rim is at
    // its origin: it reaches half its size each way), so a sphere of half the cube's diagonal
    // holds it in any orientation.
    const double reach = 0.5 * std::sqrt(3.0) * size;
    const double gap = o.cell_size;  // m between neighbouring spheres
    const double y = top + gap + reach;
    top = y + reach;
    const double slack = std::max(0.0, half_width - reach);  // the sphere stays inside the walls
    const double x = draw.uniform(-slack, slack), z = draw.uniform(-slack, slack);
    const double rx = draw.uniform(0.0, 360.0), ry = draw.uniform(0.0, 360.0), rz = draw.uniform(0.0, 360.0);
    // Mass as for a thin shell: with the area, 1 kg for an object 30 cm across.
    const double mass = (size / 0.3) * (size / 0.3);
    objects += "\n[[object]]\nname = \"" + name + "\"\n" + surface + "position = " + vec3(x, y, z) +
               "\nrotation_deg = " + vec3(rx, ry, rz) + "\ncell_size = " + number(o.cell_size) +
               "\nmass = " + number(mass) + "\nmass_spring = { stiffness = " + number(kPileSpringStiffness) + ", damping = 0.5, iterations = " +
               std::to_string(o.iterations) + " }\n";
  }

  std::string scene =
      "# A random pile (ffd::random_pile_scene): seed " + std::to_string(o.seed) + ", " + std::to_string(o.objects) +
      " objects " + std::to_string(o.min_cells) + " to " + std::to_string(o.max_cells) + " cells of " +
      number(o.cell_size) + " m across,\n# dropped in a column into a box " + number(2.0 * half_width) +
      " m wide.\n\n[simulation]\ndt = 0.001\ngravity = [0.0, -9.81, 0.0]\nalpha = 1.0\nbeta = 0.5\nseed = " +
      std::to_string(o.seed) + (o.box_overlap ? "\nbox_overlap = true" : "") +
      (o.edge_contacts ? "" : "\nedge_contacts = false") +
      (o.solver_substeps ? "\nsolver_substeps = true" : "") +
      "\neffects = [\"gravity\", \"planes\", \"inter_collision\", \"self_collision\", \"friction\", \"probe\", \"grab\"]\n"
      // The probe's proxy stays at its start until a device moves it: a cell clear above the
      // column, where nothing falls on it (its default start lies in the drop column).
      "\n[probe]\nstart = " + vec3(0.0, top + o.cell_size + ProbeSettings{}.radius, 0.0) + "  # m\n"
      "\n[[plane]]\nname = \"floor\"\nnormal = [0.0, 1.0, 0.0]\noffset = 0.0\n";
  const struct {
    const char* name;
    double x, z;
  } walls[] = {{"wall_x_low", 1, 0}, {"wall_x_high", -1, 0}, {"wall_z_low", 0, 1}, {"wall_z_high", 0, -1}};
  for (const auto& w : walls)  // normals point into the box: the plane n . x = -half_width
    scene += "\n[[plane]]\nname = \"" + std::string(w.name) + "\"\nnormal = " + vec3(w.x, 0.0, w.z) +
             "\noffset = " + number(-half_width) + "\n";
  return scene + objects;
}

}  // namespace ffd
