// Exports from run and replay: deformed surfaces as OBJ and PLY, and the per-step time series
// as CSV and JSON (docs/command-line.md, "Exports").
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "ffd/mesh_import.h"
#include "support/run_ffdsim.h"

namespace {

const std::string kReplays = std::string(FFDSIM_SCENARIO_DIR) + "/replays/";

std::vector<std::vector<std::string>> read_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  REQUIRE(in);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream s(line);
    std::string field;
    while (std::getline(s, field, ',')) fields.push_back(field);
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    rows.push_back(fields);
  }
  return rows;
}

std::size_t column(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t c = 0; c < header.size(); ++c)
    if (header[c] == name) return c;
  FAIL("no column " << name);
  return 0;
}

}  // namespace

TEST_CASE("replay exports surfaces as OBJ and PLY and a per-step series as CSV and JSON that agree", "[cli]") {
  const std::filesystem::path dir = test::fresh_temp_dir("exports_replay");
  const std::string script = kReplays + "poke_teapot.toml";  // 2000 steps, two teapots, a probe
  const std::string common = "replay --fast -q --skip-latency " + script + " --surfaces-every 500 ";
  test::ProgramResult r = test::run_ffdsim(common + "--surfaces " + (dir / "obj").string() + " --series " +
                                           (dir / "series.csv").string());
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  r = test::run_ffdsim(common + "--surfaces " + (dir / "ply").string() + " --surface-format ply --series " +
                       (dir / "series.json").string());
  REQUIRE(r.exit_code == 0);

  // Steps 0, 500, ..., 2000 for both teapots, in each format; the same surfaces.
  for (const char* object : {"teapot_low", "teapot_high"})
    for (const char* step : {"000000", "000500", "001000", "001500", "002000"}) {
      const std::string name = std::string(object) + "_" + step;
      INFO(name);
      REQUIRE(std::filesystem::exists(dir / "obj" / (name + ".obj")));
      REQUIRE(std::filesystem::exists(dir / "ply" / (name + ".ply")));
      const ffd::SurfaceMesh obj = ffd::import_mesh((dir / "obj" / (name + ".obj")).string());
      const ffd::SurfaceMesh ply = ffd::import_mesh((dir / "ply" / (name + ".ply")).string());
      REQUIRE(obj.vertices.size() == ply.vertices.size());
      CHECK(obj.triangles == ply.triangles);
      double largest = 0.0;  // OBJ has 9 significant digits, PLY the doubles
      for (std::size_t v = 0; v < obj.vertices.size(); ++v)
        largest = std::max(largest, (obj.vertices[v] - ply.vertices[v]).cwiseAbs().maxCoeff());
      CHECK(largest < 1e-8);
    }
  // The surfaces move: the upper teapot falls between step 0 and step 500.
  CHECK(ffd::import_mesh((dir / "obj" / "teapot_high_000000.obj").string()).vertices[0] !=
        ffd::import_mesh((dir / "obj" / "teapot_high_000500.obj").string()).vertices[0]);

  // The CSV: a header and one row per step, every field a number (stages that did not run empty).
  const auto csv = read_csv(dir / "series.csv");
  REQUIRE(csv.size() == 2001);
  const std::vector<std::string>& header = csv[0];
  for (const char* name : {"step", "time_s", "compute_us", "energy_j", "kinetic_j", "contacts", "max_penetration_m",
                           "probe_force_n", "dynamics_us", "narrow_phase_us"})
    CHECK(std::find(header.begin(), header.end(), name) != header.end());
  for (std::size_t i = 1; i < csv.size(); ++i) {
    REQUIRE(csv[i].size() == header.size());
    CHECK(std::stoull(csv[i][column(header, "step")]) == i);
    CHECK_FALSE(csv[i][column(header, "energy_j")].empty());  // every step's energy with --series
  }
  // The JSON: the same columns; its values equal the CSV's to its 9 digits.
  std::ifstream json_file(dir / "series.json");
  const nlohmann::json json = nlohmann::json::parse(json_file);
  CHECK(json.at("steps") == 2000);
  const nlohmann::json& series = json.at("series");
  CHECK(series.size() == header.size());
  for (const char* name : {"energy_j", "contacts", "probe_force_n"})
    for (std::size_t i : {1u, 700u, 1300u, 2000u}) {
      INFO(name << " at step " << i);
      const double from_csv = std::stod(csv[i][column(header, name)]);
      CHECK(series.at(name).at(i - 1).get<double>() == Approx(from_csv).epsilon(1e-8).margin(1e-12));
    }
  // Something happens in it: contacts once the teapots meet, a probe force while it presses.
  double most_contacts = 0.0, most_force = 0.0;
  for (const nlohmann::json& c : series.at("contacts")) most_contacts = std::max(most_contacts, c.get<double>());
  for (const nlohmann::json& f : series.at("probe_force_n")) most_force = std::max(most_force, f.get<double>());
  CHECK(most_contacts > 10);
  CHECK(most_force > 1.0);
  std::filesystem::remove_all(dir);
}

TEST_CASE("run exports its surfaces and series as it goes, and refuses a series file it cannot name", "[cli]") {
  const std::filesystem::path dir = test::fresh_temp_dir("exports_run");
  const std::string scene = std::string(FFDSIM_TEST_DATA_DIR) + "/scenes/minimal.toml";
  const std::string report = (dir / "report.json").string();
  test::ProgramResult r =
      test::run_ffdsim("run --headless --seconds 0.5 " + scene + " --surfaces-every 100 --surfaces " +
                       (dir / "surfaces").string() + " --series " + (dir / "series.csv").string() + " --report " + report);
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.output, Catch::Contains("surfaces: "));
  CHECK_THAT(r.output, Catch::Contains(" steps x 1 objects in " + (dir / "surfaces").string()));
  std::ifstream in(report);
  const std::uint64_t steps = nlohmann::json::parse(in).at("steps").get<std::uint64_t>();
  // Every step the loop took has its row, and a surface every 100 steps from step 0.
  CHECK(read_csv(dir / "series.csv").size() == steps + 1);
  std::size_t surfaces = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir / "surfaces")) surfaces += entry.path().extension() == ".obj";
  CHECK(surfaces == steps / 100 + 1);
  r = test::run_ffdsim("run --headless --seconds 0.2 " + scene + " --series " + (dir / "series.txt").string());
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.output, Catch::Contains("series.txt: the time series is written as .csv or .json"));
  r = test::run_ffdsim("replay --fast " + kReplays + "poke_teapot.toml --surface-format stl");
  CHECK(r.exit_code == 1);
  std::filesystem::remove_all(dir);
}

TEST_CASE("replay: a series that cannot be written is an error, and the results and report are still there", "[cli]") {
  const std::filesystem::path dir = test::fresh_temp_dir("exports_full");
  std::filesystem::create_directories(dir);
  std::filesystem::create_symlink("/dev/full", dir / "series.csv");  // every write fails: a full disk
  const std::string report = (dir / "report.json").string();
  const test::ProgramResult r = test::run_ffdsim("replay --fast --skip-latency " + kReplays + "poke_teapot.toml --series " +
                                                 (dir / "series.csv").string() + " --report " + report);
  INFO(r.output);
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.output, Catch::Contains((dir / "series.csv").string() + ": write failed"));
  CHECK_THAT(r.output, Catch::Contains("passed: all"));  // the assertions were printed
  std::ifstream in(report);
  REQUIRE(in);
  CHECK(nlohmann::json::parse(in).at("passed") == true);
  std::filesystem::remove_all(dir);
}
