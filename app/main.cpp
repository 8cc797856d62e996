// bondem command-line entry point: parses arguments, loads the case, calls the library.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <type_traits>
#include <variant>
#include <vector>

#if defined(__GLIBC__)  // set by the headers above
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>
#endif

#include "default_case.hpp"
#include "io/atomic_file.hpp"
#include "io/case_file.hpp"
#include "io/run.hpp"
#include "solver/engine/particles.hpp"
#include "solver/engine/staggered_vector.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/experiments/calculator.hpp"
#include "solver/experiments/collision.hpp"
#include "solver/models/contact_laws.hpp"

#if defined(BONDEM_WITH_MPI)
#include <mpi.h>

#include "io/run_mpi.hpp"
#endif

namespace {

using bondem::Case;
using bondem::kSpeedOfLight;

/// Exit status for bad input of any kind (case file, options, values).
constexpr int kBadInput = 2;

#if defined(__GLIBC__) && defined(MADV_HUGEPAGE)
/// Heap that malloc grows at once and that is advised for huge pages (advise_heap_huge_pages).
constexpr std::size_t kHugeHeapBytes = std::size_t{16} << 20;

/// Grows malloc's heap, which holds the buffers below kOwnMappingBytes, by kHugeHeapBytes at once
/// and advises that span for transparent huge pages: its first touches then cost one fault per
/// 2 MiB instead of 512. In this virtual machine a page's first write is what costs (the host
/// backs it then): a one-step run of the 20 800 peer lattice, whose particle and pair arrays all
/// live in the heap, took 61 ms against 77 ms (ten runs each; a 32 MiB span 53 ms, but 11 MB more
/// peak memory at 10^6 particles, where 16 MiB adds 4.5 MB; glibc's own
/// `glibc.malloc.hugetlb=1` also advised the large buffers' tails, 14 MB more). The loop's speed
/// did not change. Advice only: a kernel without transparent huge pages ignores it. The heap is
/// not trimmed below the span, which would split off the advised part.
void advise_heap_huge_pages() {
  mallopt(M_TOP_PAD, static_cast<int>(kHugeHeapBytes));
  mallopt(M_TRIM_THRESHOLD, static_cast<int>(2 * kHugeHeapBytes));
  // Larger than the heap's room at start-up, smaller than a mapping of its own: the heap grows.
  void* probe = std::malloc(bondem::kOwnMappingBytes / 2);
  if (probe == nullptr) return;
  const auto start = reinterpret_cast<std::uintptr_t>(probe);
  const auto end = reinterpret_cast<std::uintptr_t>(sbrk(0));
  constexpr std::uintptr_t kHuge = bondem::kHugePageBytes;
  const std::uintptr_t first = (start + kHuge - 1) / kHuge * kHuge;
  const std::uintptr_t last = end / kHuge * kHuge;
  // Only within the heap as it is now (a probe from elsewhere, or a heap that did not grow, has
  // no span to advise).
  if (end != static_cast<std::uintptr_t>(-1) && start < end && first < last) {
    madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
  }
  std::free(probe);
}
#endif

/// A bad command-line value; reported like a case error.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Mean radius of the case's particles of each material (0 when a material has none).
std::vector<double> reference_radii(const Case& c) {
  std::vector<double> sum(c.materials.size(), 0.0);
  std::vector<double> count(c.materials.size(), 0.0);
  for (const auto& p : c.particles) {
    sum[static_cast<std::size_t>(p.material)] += p.radius;
    count[static_cast<std::size_t>(p.material)] += 1.0;
  }
  for (std::size_t m = 0; m < sum.size(); ++m) sum[m] = count[m] > 0.0 ? sum[m] / count[m] : 0.0;
  return sum;
}

void print_quantity(const std::string& name, double value, const std::string& unit) {
  std::cout << name << " = " << std::setprecision(6) << value;
  if (!unit.empty()) std::cout << " " << unit;
  std::cout << "\n";
}

/// The contact model of a material pair: damping ratio and restitution (each from the other by
/// the normal law's relation), friction, rolling resistance and cohesion.
void print_contact_model(const Case& c, const bondem::PairCoefficients& pair) {
  const double restitution = bondem::restitution_of(c.normal_law, pair.contact_damping);
  print_quantity("contact_damping_ratio", pair.contact_damping, "");
  print_quantity("contact_restitution", restitution, "");
  std::cout << "# restitution "
            << (pair.restitution > 0.0 ? "given, damping ratio derived"
                                       : "derived from the damping ratio")
            << "\n";
  print_quantity("friction", pair.friction, "");
  print_quantity("rolling_friction", pair.rolling_friction, "");
  std::cout << "rolling_model = "
            << (pair.rolling_model == bondem::RollingModel::kEpsd ? "epsd" : "constant_torque")
            << "\n";
  switch (pair.cohesion) {
    case bondem::CohesionModel::kNone:
      std::cout << "cohesion = none\n";
      break;
    case bondem::CohesionModel::kSjkr:
      std::cout << "cohesion = sjkr\n";
      print_quantity("cohesion_energy_density", pair.cohesion_energy, "J/m^3");
      break;
    case bondem::CohesionModel::kJkr:
      std::cout << "cohesion = jkr\n";
      print_quantity("surface_energy", pair.cohesion_energy, "J/m^2");
      break;
  }
}

/// JKR quantities of a pair of effective radius @p r_star: pull-off force, separation overlap and,
/// for a particle pair of effective mass @p m_star (0 for a wall or tool), the sticking velocity.
void print_cohesion_scales(const bondem::PairCoefficients& pair, double r_star, double m_star) {
  if (pair.cohesion != bondem::CohesionModel::kJkr) return;
  const double w = pair.cohesion_energy;
  print_quantity("jkr_pull_off_force", bondem::jkr_pull_off_force(r_star, w), "N");
  print_quantity("jkr_separation_overlap", bondem::separation_overlap(pair, r_star), "m");
  if (m_star > 0.0) {
    // Below it an undamped pair cannot pay one JKR cycle's loss: 1/2 m* V^2 = W.
    print_quantity(
        "jkr_sticking_velocity",
        std::sqrt(2.0 * bondem::jkr_cycle_energy_loss(r_star, pair.effective_modulus, w) / m_star),
        "m/s");
  }
}

/// One section per boundary: its shape (a mesh with its triangle count and file), material, where
/// it is at the start (the bounding box of a bounded shape: the check of an STL file's scale and
/// offset) and its motion.
void print_boundaries(const Case& c) {
  for (const bondem::Boundary& boundary : c.boundaries) {
    std::cout << "[boundary " << boundary.name << "]\n";
    std::visit(
        [&](const auto& shape) {
          using Shape = std::decay_t<decltype(shape)>;
          Eigen::Vector3d lo = boundary.center;
          Eigen::Vector3d hi = boundary.center;
          bool bounded = true;
          if constexpr (std::is_same_v<Shape, bondem::PlaneShape>) {
            std::cout << "shape = plane\n";
            bounded = false;
          } else if constexpr (std::is_same_v<Shape, bondem::CylinderShape>) {
            std::cout << "shape = roller\n";
            bounded = false;
          } else if constexpr (std::is_same_v<Shape, bondem::BoxShape>) {
            std::cout << "shape = blade\n";
            lo -= shape.half_size;
            hi += shape.half_size;
          } else if constexpr (std::is_same_v<Shape, bondem::SphereShape>) {
            std::cout << "shape = sphere\n";
            lo.array() -= shape.radius;
            hi.array() += shape.radius;
          } else {
            std::cout << "shape = mesh\n";
            std::cout << "triangles = " << shape.surface->mesh.triangles.size() << "\n";
            std::cout << "file = " << shape.surface->file << "\n";
            // At angle 0 the frame is the world's: the box is the file's, placed.
            lo += shape.surface->box_min;
            hi += shape.surface->box_max;
          }
          if (bounded) {
            std::cout << "bounding_box = [" << lo.x() << " " << lo.y() << " " << lo.z() << "] .. ["
                      << hi.x() << " " << hi.y() << " " << hi.z() << "] m\n";
          }
        },
        boundary.shape);
    std::cout << "material = " << c.materials[static_cast<std::size_t>(boundary.material)].name
              << "\n";
    if (boundary.temperature > 0.0) print_quantity("temperature", boundary.temperature, "K");
    if (boundary.motion.moves()) {
      print_quantity("max_surface_speed", bondem::tool_surface_speed(boundary), "m/s");
    } else {
      std::cout << "motion = fixed\n";
    }
  }
}

/// Select the SIMD pass's target from --simd; an unknown name or one this CPU lacks is a usage
/// error naming what it supports.
void select_simd(const std::string& name) {
  const std::optional<bondem::SimdTarget> target = bondem::parse_simd_target(name);
  if (!target) {
    throw UsageError("--simd " + name + ": unknown target (auto, scalar, sse4, avx2, avx512)");
  }
  bondem::select_simd_target(*target);  // std::invalid_argument naming the supported ones
}

/// Which pass evaluates the case's pairs: "pair pass SIMD avx512", or "pair pass scalar (why)".
std::string pair_pass_text(const Case& c) {
  std::vector<bondem::PairCoefficients> table;
  const int n = static_cast<int>(c.materials.size());
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) table.push_back(c.pair_coefficients(a, b));
  }
  const char* reason = bondem::scalar_pass_reason(c.normal_law, table, c.thermal.has_value());
  if (reason != nullptr) return std::string("pair pass scalar (") + reason + ")";
  return std::string("pair pass SIMD ") + bondem::simd_target_name(bondem::simd_target_in_use());
}

int run_info(const std::string& case_path, const std::vector<std::string>& overrides,
             std::optional<double> velocity, const std::string& simd) {
  select_simd(simd);
  const Case c = bondem::load_case(case_path, overrides);
  // First: a non-finite or unphysical derived quantity is an input error, before any output.
  const bondem::TimeStepLimit limit = bondem::case_time_step_bound(c);
  if (velocity && !(*velocity > 0.0 && std::isfinite(*velocity))) {
    throw UsageError("--velocity must be a positive finite speed");
  }
  const double reference = velocity.value_or(bondem::reference_impact_speed(c));
  const char* reference_source =
      velocity ? "--velocity" : "fastest impact of the case (initial speeds, fall under gravity)";
  const std::vector<double> radii = reference_radii(c);
  const std::size_t n = c.materials.size();
  std::cout << "# bond calculator for " << case_path << "; radii are the mean of each material's"
            << " particles; reference impact speed: " << reference_source << "\n"
            << "# " << pair_pass_text(c) << "\n";
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a; b < n; ++b) {
      const bondem::PairCoefficients pair =
          c.pair_coefficients(static_cast<int>(a), static_cast<int>(b));
      if (radii[a] == 0.0 || radii[b] == 0.0) {
        std::cout << "[" << c.materials[a].name << " " << c.materials[b].name << "]\n";
        print_contact_model(c, pair);
        // A material without particles meets the others only as a wall or tool: r* = r.
        const double radius = std::max(radii[a], radii[b]);
        if (radius > 0.0) print_cohesion_scales(pair, radius, 0.0);
        std::cout << "# no particles of one material: the pair's particle quantities skipped\n";
        continue;
      }
      const auto r = bondem::compute_pair_report(c, static_cast<int>(a), radii[a],
                                                 static_cast<int>(b), radii[b], reference);
      std::cout << "[" << c.materials[a].name << " " << c.materials[b].name << "]\n";
      print_quantity("radius_a", radii[a], "m");
      print_quantity("radius_b", radii[b], "m");
      print_quantity("effective_modulus", r.effective_modulus, "Pa");
      print_quantity("effective_radius", r.effective_radius, "m");
      print_quantity("effective_mass", r.effective_mass, "kg");
      print_contact_model(c, pair);
      print_cohesion_scales(pair, r.effective_radius, r.effective_mass);
      if (r.bonding) {
        print_quantity("alpha", pair.alpha, "");
        print_quantity("adhesion_stiffness", r.adhesion_stiffness,
                       pair.alpha == 1.0 ? "N/m" : "N/m^" + std::to_string(pair.alpha));
        print_quantity("equilibrium_overlap", r.equilibrium_overlap, "m");
        print_quantity("critical_overlap", r.critical_overlap, "m");
        print_quantity("critical_velocity", r.critical_velocity, "m/s");
        print_quantity("bond_stiffness_at_equilibrium", r.bond_stiffness, "N/m");
        print_quantity("bond_period", r.bond_period, "s");
      } else {
        std::cout << "# no bond (no bond: block, or criterion never): bond quantities omitted\n";
      }
      print_quantity("reference_velocity", r.reference_velocity, "m/s");
      print_quantity("hertz_max_overlap", r.max_overlap, "m");
      print_quantity("hertz_contact_time", r.contact_time, "s");
      print_quantity("rayleigh_time", r.rayleigh_time, "s");
      print_quantity("contact_damper_time_step", r.contact_damper_step, "s");
      if (r.bonding) print_quantity("bond_damper_time_step", r.bond_damper_step, "s");
      print_quantity("recommended_time_step", r.recommended_time_step, "s");
      print_quantity("time_step", c.time_step, "s");
      print_quantity("steps_per_contact", r.contact_time / c.time_step, "");
      for (const std::string& w : bondem::time_step_warnings(r, c.time_step)) {
        std::cerr << "warning: [" << c.materials[a].name << " " << c.materials[b].name << "] " << w
                  << "\n";
      }
    }
  }
  print_boundaries(c);
  std::cout << "# case time-step limit set by " << limit.cause << "\n";
  print_quantity("case_time_step_limit", limit.step, "s");
  return 0;
}

std::string json_number(double value) {
  std::ostringstream out;
  out << std::setprecision(12) << value;
  return out.str();
}

void print_result(const bondem::CollisionResult& r, bool json) {
  const std::string contact_time = r.contact_time ? json_number(*r.contact_time) : "null";
  if (json) {
    std::cout << "{\"restitution\": " << json_number(r.restitution)
              << ", \"bonded\": " << (r.bonded ? "true" : "false")
              << ", \"stuck\": " << (r.stuck ? "true" : "false")
              << ", \"max_overlap\": " << json_number(r.max_overlap)
              << ", \"contact_time\": " << contact_time
              << ", \"final_overlap\": " << json_number(r.final_overlap) << "}\n";
    return;
  }
  std::cout << "restitution = " << json_number(r.restitution) << "\n"
            << "bonded = " << (r.bonded ? "true" : "false") << "\n"
            << "stuck = " << (r.stuck ? "true" : "false") << "\n"
            << "bond_formed = " << (r.bond_formed ? "true" : "false") << "\n"
            << "max_overlap = " << json_number(r.max_overlap) << " m\n"
            << "contact_time = " << contact_time << (r.contact_time ? " s" : "") << "\n"
            << "final_overlap = " << json_number(r.final_overlap) << " m\n";
}

/// Parse "A:B" or "A:B:N" into numbers.
std::vector<double> parse_range(const std::string& text, std::size_t parts, const char* option) {
  std::vector<double> values;
  std::stringstream stream(text);
  for (std::string item; std::getline(stream, item, ':');) {
    try {
      std::size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw UsageError(
          std::string(option).append(" ").append(text).append(": '").append(item).append(
              "' is not a number"));
    }
  }
  if (values.size() != parts) {
    throw UsageError(std::string(option) + " " + text + ": expected " +
                     (parts == 3 ? "V0:V1:N" : "V0:V1"));
  }
  if (!(values[0] > 0.0 && values[1] > values[0] && values[1] < kSpeedOfLight)) {
    throw UsageError(std::string(option) + " " + text +
                     ": need 0 < V0 < V1 below the speed of light");
  }
  return values;
}

void warn_time_step(const Case& c, double velocity) {
  const auto report =
      bondem::compute_pair_report(c, c.particles[0].material, c.particles[0].radius,
                                  c.particles[1].material, c.particles[1].radius, velocity);
  for (const std::string& w : bondem::time_step_warnings(report, c.time_step)) {
    std::cerr << "warning: " << w << "\n";
  }
}

struct CollideOptions {
  std::string case_path;
  std::vector<std::string> overrides;
  std::optional<double> velocity;
  bool json = false;
  std::string trace_path;
  std::string sweep;
  std::string out_path;
  std::string threshold;
};

int run_collide(const CollideOptions& o) {
  const Case c = bondem::load_case(o.case_path, o.overrides);
  if (c.particles.size() != 2) {
    throw UsageError(o.case_path + ": collide needs exactly two particles, the case has " +
                     std::to_string(c.particles.size()));
  }
  const int modes =
      (o.velocity ? 1 : 0) + (o.sweep.empty() ? 0 : 1) + (o.threshold.empty() ? 0 : 1);
  if (modes != 1) throw UsageError("collide: give exactly one of --velocity, --sweep, --threshold");
  if (o.velocity && !(*o.velocity > 0.0 && *o.velocity < kSpeedOfLight)) {
    throw UsageError("--velocity " + json_number(*o.velocity) +
                     ": need a positive speed below the speed of light");
  }

  if (!o.sweep.empty()) {
    if (o.out_path.empty()) throw UsageError("collide --sweep needs --out FILE.csv");
    const auto range = parse_range(o.sweep, 3, "--sweep");
    const double count = range[2];
    if (count < 2.0 || count != std::floor(count)) {
      throw UsageError("--sweep " + o.sweep + ": N must be an integer of at least 2");
    }
    warn_time_step(c, range[1]);
    bondem::AtomicFile out(o.out_path);
    out.stream() << "velocity,restitution,bonded,max_overlap,contact_time,final_overlap,stuck\n";
    const auto n = static_cast<int>(count);
    for (int k = 0; k < n; ++k) {
      const double v = range[0] + (range[1] - range[0]) * k / (n - 1);
      const auto r = bondem::collide(c, v);
      out.stream() << v << "," << r.restitution << "," << (r.bonded ? 1 : 0) << "," << r.max_overlap
                   << "," << (r.contact_time ? json_number(*r.contact_time) : "") << ","
                   << r.final_overlap << "," << (r.stuck ? 1 : 0) << "\n";
    }
    out.commit();
    return 0;
  }

  if (!o.threshold.empty()) {
    const auto range = parse_range(o.threshold, 2, "--threshold");
    warn_time_step(c, range[1]);
    const auto found = bondem::sticking_threshold(c, range[0], range[1]);
    if (!found) {
      throw UsageError("--threshold " + o.threshold +
                       ": the pair must stick at one of V0, V1 and rebound at the other to bracket "
                       "the threshold");
    }
    const double threshold = found->velocity;
    const bool sticks_below = found->sticks_below;
    if (o.json) {
      std::cout << "{\"sticking_threshold\": " << json_number(threshold)
                << ", \"sticks_below\": " << (sticks_below ? "true" : "false") << "}\n";
    } else {
      std::cout << "sticking_threshold = " << json_number(threshold) << " m/s\n"
                << "sticks_below = " << (sticks_below ? "true" : "false") << "\n";
    }
    return 0;
  }

  warn_time_step(c, *o.velocity);
  std::optional<bondem::AtomicFile> trace_file;
  std::function<void(const bondem::CollisionSample&)> trace;
  if (!o.trace_path.empty()) {
    trace_file.emplace(o.trace_path);
    trace_file->stream() << "time,overlap,overlap_rate,normal_force,bonded\n";
    trace = [&](const bondem::CollisionSample& s) {
      trace_file->stream() << s.time << "," << s.overlap << "," << s.overlap_rate << ","
                           << s.normal_force << "," << (s.bonded ? 1 : 0) << "\n";
    };
  }
  const auto result = bondem::collide(c, *o.velocity, trace);
  if (trace_file) trace_file->commit();
  print_result(result, o.json);
  return 0;
}

/// Set by SIGINT/SIGTERM; the run loop stops after the current step.
volatile std::sig_atomic_t g_stop_signal = 0;

extern "C" void request_stop(int signal_number) {
  g_stop_signal = signal_number;
}

struct RunCommand {
  std::string restart;
  bool unsafe_time_step = false;
  std::string case_path;
  std::vector<std::string> overrides;
  std::optional<int> threads;
  std::string simd = "auto";
  std::string output;
  bool quiet = false;
  std::vector<std::string> command_line;  ///< argv, for the resume command
};

/// Most OpenMP threads a run accepts: 4 x the hardware threads. More cannot run faster (they only
/// take turns on the cores), and far beyond it team creation fails inside the OpenMP runtime.
int thread_limit() {
  const int hardware =
      std::max(static_cast<int>(std::thread::hardware_concurrency()), omp_get_num_procs());
  return 4 * std::max(hardware, 1);
}

/// Processes of this MPI job on this machine (1 outside one), set by main.
int g_local_ranks = 1;

/// The threads a process takes when neither --threads nor OMP_NUM_THREADS says: every core it
/// may run on, shared with the other processes of its MPI job on this machine when the launcher
/// did not bind it (`mpirun -np 2` on 2 cores: 1 each; two teams of 2 would take turns on the
/// cores, each spinning while the other works, 25 times slower measured).
int default_threads() {
  const int hardware = std::max(static_cast<int>(std::thread::hardware_concurrency()), 1);
  const int allowed = omp_get_num_procs();  // the cores of this process's affinity mask
  if (g_local_ranks <= 1 || allowed < hardware) return std::max(allowed, 1);  // bound: its cores
  return std::max(hardware / g_local_ranks, 1);
}

/// Set the OpenMP team size from --threads, or check the one OMP_NUM_THREADS gave.
void set_threads(const std::optional<int>& requested) {
  const int limit = thread_limit();
  const std::string limit_text =
      std::to_string(limit) + " (4 x the " + std::to_string(limit / 4) + " hardware threads)";
  if (requested) {
    if (*requested < 1) throw UsageError("--threads must be at least 1");
    if (*requested > limit) {
      throw UsageError("--threads " + std::to_string(*requested) + " exceeds the limit of " +
                       limit_text);
    }
    omp_set_num_threads(*requested);
  } else if (std::getenv("OMP_NUM_THREADS") == nullptr) {
    omp_set_num_threads(default_threads());
  } else if (omp_get_max_threads() > limit) {
    throw UsageError("OMP_NUM_THREADS asks for " + std::to_string(omp_get_max_threads()) +
                     " threads, above the limit of " + limit_text + "; lower it or pass --threads");
  }
}

/// A bed measure as printed: its value, or "n/a (why)" when the region is too small to mean
/// anything.
std::string measured(const std::optional<double>& value, const bondem::PackingReport& report) {
  if (!value) return "n/a (" + report.unmeasured_reason + ")";
  std::ostringstream text;
  text << *value;
  return text.str();
}

/// The number of processes of the MPI job this process belongs to, from the launcher's
/// environment (Open MPI sets OMPI_COMM_WORLD_SIZE; MPICH and Slurm, PMI_SIZE); 0 when not
/// launched by one.
long launched_ranks() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}) {
    if (const char* value = std::getenv(name)) {
      char* end = nullptr;
      const long ranks = std::strtol(value, &end, 10);
      if (end != value && ranks > 0) return ranks;
    }
  }
  return 0;
}

/// Whether this process is one of an MPI job's that runs decomposed (MPI initialized by main).
bool g_distributed = false;
/// This process's rank in that job (0 otherwise): only rank 0 prints.
int g_rank = 0;

int run_run(const RunCommand& o) {
#if !defined(BONDEM_WITH_MPI)
  // Each of the R processes would run the whole case into the same output directory, each
  // clobbering the others' files: refuse before touching anything.
  if (const long ranks = launched_ranks(); ranks > 1) {
    throw UsageError("launched as one of " + std::to_string(ranks) +
                     " MPI processes, but this bondem was built without MPI (install "
                     "libopenmpi-dev and rebuild), and every process would run the whole case "
                     "into the same output directory; run bondem without mpirun (its threads: "
                     "--threads)");
  }
#endif
  set_threads(o.threads);
  select_simd(o.simd);
  Case c = o.case_path.empty()
               ? bondem::parse_case(bondem::kDefaultCase, "<built-in packing case>", o.overrides)
               : bondem::load_case(o.case_path, o.overrides);
  if (!o.quiet && g_rank == 0) {
    const int threads = bondem::threads_in_use(c.particles.size());
    std::cerr << "bondem run: " << (o.case_path.empty() ? "built-in packing case" : o.case_path)
              << ", " << c.particles.size() << " particles";
    if (!c.streams.empty()) {
      std::cerr << " and " << c.streams.size() << (c.streams.size() == 1 ? " stream" : " streams");
    }
#if defined(BONDEM_WITH_MPI)
    if (g_distributed) {
      int processes = 1;
      MPI_Comm_size(MPI_COMM_WORLD, &processes);
      std::cerr << ", " << processes << (processes == 1 ? " MPI process" : " MPI processes");
    }
#endif
    std::cerr << ", " << threads << (threads == 1 ? " thread" : " threads")
              << (g_distributed ? " each" : "");
    if (threads < omp_get_max_threads()) {
      std::cerr << " (below " << bondem::kMinParallelParticles
                << " particles the loops run serially; " << omp_get_max_threads() << " available"
                << (c.streams.empty() ? "" : "; the streams add particles as it runs") << ")";
    }
    std::cerr << ", " << pair_pass_text(c) << "\n";
  }
  bondem::RunOptions options;
  options.output_directory = o.output;
  options.quiet = o.quiet;
  options.restart_path = o.restart;
  options.enforce_time_step_limit = !o.unsafe_time_step;
  options.stop_requested = &g_stop_signal;
  options.command_line = o.command_line;
  std::signal(SIGINT, request_stop);
  std::signal(SIGTERM, request_stop);
  const std::string directory = o.output.empty() ? c.output_directory : o.output;
  // Moved: the run frees the case's particle list once the scene holds the particles.
#if defined(BONDEM_WITH_MPI)
  const bondem::RunResult r = g_distributed
                                  ? bondem::run_case_distributed(std::move(c), options, std::cerr)
                                  : bondem::run_case(std::move(c), options, std::cerr);
  if (g_rank != 0) return 0;  // rank 0 reports the run
#else
  const bondem::RunResult r = bondem::run_case(std::move(c), options, std::cerr);
#endif
  std::cout << "output_directory = " << directory << "\n"
            << "particles = " << r.particles << "\n"
            << "steps = " << r.steps << "\n"
            << "threads = " << r.threads << "\n"
            << "wall_time = " << r.wall_seconds << " s\n"
            << "particle_steps_per_second = " << r.particle_steps_per_second << "\n"
            << "neighbor_builds = " << r.neighbor_builds << "\n"
            << "contacts = " << r.contacts.contacts << "\n"
            << "bonds = " << r.contacts.bonds << "\n"
            << "wall_contacts = " << r.contacts.wall_contacts << "\n"
            << "max_overlap = " << r.contacts.max_overlap << " m\n"
            << "bed_region = [" << r.packing_region.min.transpose() << "] .. ["
            << r.packing_region.max.transpose() << "] m\n"
            << "bed_particles = " << r.packing.particles << "\n"
            << "bed_solid_fraction = " << measured(r.packing.solid_fraction, r.packing) << "\n"
            << "mean_coordination = " << measured(r.packing.mean_coordination, r.packing) << "\n"
            << "clusters = " << r.clusters << "\n"
            << "unbonded_particles = " << r.unbonded << "\n"
            << "largest_cluster = " << r.largest_cluster << "\n"
            << "primary_d10_d50_d90 = " << r.primary_sizes.d10 << " " << r.primary_sizes.d50 << " "
            << r.primary_sizes.d90 << " m\n";
  if (r.clusters > 0) {
    std::cout << "cluster_d10_d50_d90 = " << r.cluster_sizes.d10 << " " << r.cluster_sizes.d50
              << " " << r.cluster_sizes.d90 << " m\n";
  }
  std::cout << "bonds_formed = " << r.bonds_formed << "\n"
            << "bonds_broken = " << r.bonds_broken << "\n";
  if (r.thermal) {
    const bondem::ThermalReport& t = *r.thermal;
    std::cout << "peak_temperature = " << t.track.peak_temperature << " K\n"
              << "final_max_temperature = " << t.final_max_temperature << " K\n"
              << "laser_energy_absorbed = " << t.laser_energy << " J\n"
              << "laser_energy_missed = " << t.laser_missed << " J\n"
              << "track_threshold = " << t.threshold << " K\n"
              << "track_particles = " << t.track.heated << "\n"
              << "track_width = " << t.track.width << " m\n"
              << "bonded_agglomerates = " << t.clusters_of_two_or_more << "\n";
  }
  if (r.layer) {
    std::cout << "layer_solid_fraction = " << r.layer->solid_fraction << "\n"
              << "layer_mean_height = " << r.layer->mean_surface_height << " m\n"
              << "layer_roughness = " << r.layer->roughness << " m\n"
              << "layer_empty_fraction = " << r.layer->empty_fraction << "\n"
              << "layer_particles = " << r.layer->particles << "\n";
  }
  return 0;
}

/// Prints @p prefix and @p error's message on stderr; in a distributed run, where every process
/// has the same error, on rank 0 only.
void report(const char* prefix, const std::exception& error) {
  if (g_rank == 0) std::cerr << prefix << error.what() << "\n";
}

/// The command line: parse, dispatch, and map each kind of failure to its exit status.
int run_command_line(int argc, char** argv) {
  CLI::App app{"bondem: DEM with the Hertz + adhesion bond model of Quintana-Ruiz & Campello"};
  app.require_subcommand(1);

  std::string info_case;
  std::vector<std::string> info_overrides;
  std::optional<double> info_velocity;
  std::string info_simd = "auto";
  auto* info = app.add_subcommand("info", "Bond calculator: derived quantities per material pair");
  info->add_option("case", info_case, "Case file (YAML)")->required();
  // One KEY=VALUE per --set: a --set before the case file must not swallow it.
  info->add_option("--set", info_overrides, "Override a scalar: KEY=VALUE (dotted key)")
      ->allow_extra_args(false);
  info->add_option("--velocity", info_velocity, "Reference impact speed [m/s]");
  info->add_option("--simd", info_simd,
                   "SIMD target to report: auto (default), scalar, sse4, avx2, avx512");

  CollideOptions collide;
  auto* collide_cmd =
      app.add_subcommand("collide", "Central collision of the case's two particles");
  collide_cmd->add_option("case", collide.case_path, "Case file (YAML) with two particles")
      ->required();
  collide_cmd->add_option("--velocity", collide.velocity, "Relative impact speed V [m/s]");
  collide_cmd->add_option("--set", collide.overrides, "Override a scalar: KEY=VALUE (dotted key)")
      ->allow_extra_args(false);
  collide_cmd->add_flag("--json", collide.json, "Print one JSON object");
  collide_cmd->add_option("--trace", collide.trace_path, "Write the per-step history to FILE.csv");
  collide_cmd->add_option("--sweep", collide.sweep, "Impact speeds V0:V1:N (needs --out)");
  collide_cmd->add_option("--out", collide.out_path, "CSV file for --sweep");
  collide_cmd->add_option("--threshold", collide.threshold,
                          "Bisect the sticking speed between V0:V1 (stuck at one end)");

  RunCommand run;
  run.command_line.assign(argv, argv + argc);
  auto* run_cmd = app.add_subcommand(
      "run", "Run a case; without a case file, the built-in powder-bed packing case");
  run_cmd->add_option("case", run.case_path, "Case file (YAML)");
  run_cmd->add_option("--threads", run.threads,
                      "OpenMP threads (default: OMP_NUM_THREADS, or every core, shared by the MPI "
                      "processes on a machine)");
  run_cmd->add_option("--simd", run.simd,
                      "SIMD target of the pair pass: auto (default), scalar, sse4, avx2, avx512");
  run_cmd->add_option("--output", run.output, "Output directory (default: output.directory)");
  run_cmd->add_option("--set", run.overrides, "Override a scalar: KEY=VALUE (dotted key)")
      ->allow_extra_args(false);
  run_cmd->add_flag("--quiet", run.quiet, "No progress lines");
  run_cmd->add_option("--restart", run.restart, "Continue from a checkpoint file");
  run_cmd->add_flag("--unsafe-time-step", run.unsafe_time_step,
                    "Run even if time.step exceeds the recommended one (blow-ups still stop it)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One line, like every other input error.
    std::string message = e.what();
    std::replace(message.begin(), message.end(), '\n', ' ');
    std::cerr << "bondem: error: " << message << " (see bondem --help)\n";
    return kBadInput;
  }

  try {
    if (info->parsed()) return run_info(info_case, info_overrides, info_velocity, info_simd);
    if (collide_cmd->parsed()) return run_collide(collide);
    if (run_cmd->parsed()) return run_run(run);
  } catch (const bondem::RunInterrupted& e) {
    report("bondem: ", e);
    // Every process of a distributed run stops, not only those that got the signal.
    return 128 + static_cast<int>(g_stop_signal != 0 ? g_stop_signal : SIGINT);
  } catch (const bondem::BlowUpError& e) {
    report("bondem: blow-up: ", e);
    return 3;
  } catch (const bondem::CaseError& e) {
    report("bondem: error: ", e);
    return kBadInput;
  } catch (const UsageError& e) {
    report("bondem: error: ", e);
    return kBadInput;
  } catch (const std::invalid_argument& e) {
    report("bondem: error: ", e);
    return kBadInput;
  } catch (const std::exception& e) {
    report("bondem: failed: ", e);
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, static_cast<int>(bondem::kOwnMappingBytes));
#if defined(MADV_HUGEPAGE)
  advise_heap_huge_pages();
#endif
#endif
#if defined(BONDEM_WITH_MPI)
  // Launched by mpirun (any number of processes, one included): a run decomposed over them.
  if (launched_ranks() > 0) {
    int provided = 0;  // only the main thread calls MPI
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
    MPI_Comm node;  // the processes sharing this machine's cores
    MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
    MPI_Comm_size(node, &g_local_ranks);
    MPI_Comm_free(&node);
    g_distributed = true;
  }
#endif
  int status = 1;
  // Setting up the options can fail too (memory): no exception may leave main as an abort.
  try {
    status = run_command_line(argc, argv);
  } catch (...) {
    std::fputs("bondem: failed: unexpected error while reading the command line\n", stderr);
  }
#if defined(BONDEM_WITH_MPI)
  if (g_distributed) MPI_Finalize();
#endif
  return status;
}
