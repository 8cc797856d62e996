#include "io/run.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numeric>
#include <ostream>
#include <sstream>

#include "io/atomic_file.hpp"
#include "io/case_file.hpp"
#include "solver/calculator.hpp"
#include "solver/scene.hpp"
#include "solver/stepper.hpp"

namespace bondem {
namespace {

/// Shortest exact text of a double: the same bits always give the same bytes.
std::string exact(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

void write_final_state(const Particles& p, const std::string& path) {
  std::vector<std::size_t> order(p.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return p.id[a] < p.id[b]; });
  AtomicFile file(path);
  std::ostream& out = file.stream();
  out << "id,x,y,z,vx,vy,vz,radius\n";
  for (const std::size_t i : order) {
    out << p.id[i] << ',' << exact(p.x[i]) << ',' << exact(p.y[i]) << ',' << exact(p.z[i]) << ','
        << exact(p.vx[i]) << ',' << exact(p.vy[i]) << ',' << exact(p.vz[i]) << ','
        << exact(p.radius[i]) << '\n';
  }
  file.commit();
}

}  // namespace

RunResult run_case(const Case& description, const RunOptions& options, std::ostream& log) {
  const double recommended = case_time_step_limit(description);
  if (description.time_step > recommended) {
    std::ostringstream message;
    message << description.source << ": 'time.step': " << description.time_step
            << " s is above the recommended " << recommended
            << " s (min of t_contact/50, T_bond/50, 0.2 T_Rayleigh; see bondem info); "
               "lower time.step";
    throw CaseError(message.str());
  }
  const std::filesystem::path directory =
      options.output_directory.empty() ? description.output_directory : options.output_directory;

  Scene scene = build_scene(description);
  Stepper stepper(scene);
  const auto steps =
      static_cast<std::int64_t>(std::llround(description.end_time / description.time_step));
  const double interval = description.history_interval > 0.0 ? description.history_interval
                                                             : description.end_time / 100.0;
  const auto history_every =
      std::max<std::int64_t>(1, std::llround(interval / description.time_step));

  AtomicFile history((directory / "history.csv").string());
  history.stream() << "time,kinetic_energy,contacts,bonds,wall_contacts,max_overlap\n";
  const auto record = [&] {
    const ContactSummary& c = stepper.contacts();
    history.stream() << exact(stepper.time()) << ',' << exact(stepper.kinetic_energy()) << ','
                     << c.contacts << ',' << c.bonds << ',' << c.wall_contacts << ','
                     << exact(c.max_overlap) << '\n';
  };
  record();

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto last_report = start;
  const std::size_t n = scene.particles.size();
  for (std::int64_t s = 1; s <= steps; ++s) {
    stepper.step();
    if (s % history_every == 0 || s == steps) record();
    if (!options.quiet && (s & 63) == 0) {
      const auto now = Clock::now();
      if (now - last_report > std::chrono::seconds(5)) {
        last_report = now;
        const double elapsed = std::chrono::duration<double>(now - start).count();
        const double rate = static_cast<double>(s) / elapsed;
        log << "t = " << stepper.time() << " s ("
            << 100.0 * static_cast<double>(s) / static_cast<double>(steps) << " %), " << rate
            << " steps/s, " << rate * static_cast<double>(n) << " particle-steps/s, "
            << static_cast<double>(steps - s) / rate << " s left\n";
      }
    }
  }
  const double wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  history.commit();
  write_final_state(scene.particles, (directory / "final_state.csv").string());

  RunResult result;
  result.steps = steps;
  result.particles = n;
  result.threads = omp_get_max_threads();
  result.wall_seconds = wall_seconds;
  result.particle_steps_per_second =
      wall_seconds > 0.0 ? static_cast<double>(steps) * static_cast<double>(n) / wall_seconds : 0.0;
  result.neighbor_builds = stepper.neighbors().builds;
  result.contacts = stepper.contacts();
  double max_radius = 0.0;
  for (const double r : scene.particles.radius) max_radius = std::max(max_radius, r);
  result.packing_region =
      description.analysis_region
          ? *description.analysis_region
          : bed_region(scene.particles, Box{scene.domain.min, scene.domain.max}, 4.0 * max_radius);
  result.packing = analyse_packing(scene.particles, stepper.neighbors(), result.packing_region);
  return result;
}

}  // namespace bondem
