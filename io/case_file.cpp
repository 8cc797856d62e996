#include "io/case_file.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <variant>

#include "io/checkpoint.hpp"
#include "io/stl_reader.hpp"
#include "solver/analysis/packing.hpp"
#include "solver/setup/insertion.hpp"
#include "solver/setup/message_number.hpp"

namespace bondem {
namespace {

/// Where a value came from, so that every message can point at it.
class Reader {
 public:
  Reader(std::string source, std::map<std::string, std::string> overrides)
      : source_(std::move(source)), overrides_(std::move(overrides)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& path,
                         const std::string& what) const {
    throw CaseError(origin(node, path) + ": " + what);
  }

  /// Where @p node (at key @p path) came from, as fail() names it: `file:line:column: 'path'`, or
  /// the --set that gave it.
  std::string origin(const YAML::Node& node, const std::string& path) const {
    std::ostringstream message;
    // The --set that gave this value, or one element of it (a list such as a velocity).
    auto set = overrides_.find(path);
    if (set == overrides_.end() && !path.empty()) {
      set = overrides_.lower_bound(path + ".");
      if (set != overrides_.end() && set->first.rfind(path + ".", 0) != 0) set = overrides_.end();
    }
    if (set != overrides_.end()) {
      message << "--set " << set->first << "=" << set->second;
    } else {
      message << source_;
      const YAML::Mark mark = node.Mark();
      if (mark.line >= 0) message << ":" << mark.line + 1 << ":" << mark.column + 1;
    }
    message << ": " << (path.empty() ? "case" : "'" + path + "'");
    return message.str();
  }

  void expect_map(const YAML::Node& node, const std::string& path) const {
    if (!node.IsMap()) fail(node, path, "expected a mapping of keys to values");
    record(path, "{}");
  }

  /// Unknown and repeated keys are errors: a typo must never be silently ignored.
  void check_keys(const YAML::Node& node, const std::string& path,
                  const std::vector<std::string>& allowed) const {
    std::vector<std::string> seen;
    for (const auto& entry : node) {
      const YAML::Node& key_node = entry.first;
      if (!key_node.IsScalar()) fail(key_node, path, "keys must be plain names");
      const std::string key = key_node.Scalar();
      const std::string key_path = join(path, key);
      if (std::find(seen.begin(), seen.end(), key) != seen.end()) {
        fail(key_node, key_path, "key given twice");
      }
      seen.push_back(key);
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        std::string expected;
        for (const std::string& name : allowed) expected += (expected.empty() ? "" : ", ") + name;
        fail(key_node, key_path, "unknown key (expected one of: " + expected + ")");
      }
    }
  }

  YAML::Node require(const YAML::Node& parent, const std::string& path,
                     const std::string& key) const {
    const YAML::Node child = parent[key];
    if (!child) fail(parent, join(path, key), "missing required key");
    return child;
  }

  double number(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar()) fail(node, path, "expected a number");
    double value = 0.0;
    if (!YAML::convert<double>::decode(node, value)) {
      fail(node, path, "expected a number, got '" + node.Scalar() + "'");
    }
    if (!std::isfinite(value)) fail(node, path, "must be finite, got '" + node.Scalar() + "'");
    std::array<char, 32> shortest{};
    const std::to_chars_result written =
        std::to_chars(shortest.data(), shortest.data() + shortest.size(), value);
    record(path, std::string(shortest.data(), written.ptr));
    return value;
  }

  double positive(const YAML::Node& node, const std::string& path) const {
    const double value = number(node, path);
    if (!(value > 0.0)) fail(node, path, "must be positive, got " + node.Scalar());
    return value;
  }

  double non_negative(const YAML::Node& node, const std::string& path) const {
    const double value = number(node, path);
    if (value < 0.0) fail(node, path, "must not be negative, got " + node.Scalar());
    return value;
  }

  /// A number in [0, 1] (absorptivity, emissivity).
  double fraction(const YAML::Node& node, const std::string& path) const {
    const double value = number(node, path);
    if (!(value >= 0.0 && value <= 1.0)) {
      fail(node, path, "must lie in [0, 1], got " + node.Scalar());
    }
    return value;
  }

  long long integer(const YAML::Node& node, const std::string& path, long long lo,
                    long long hi) const {
    if (!node.IsScalar()) fail(node, path, "expected a whole number");
    long long value = 0;
    if (!YAML::convert<long long>::decode(node, value)) {
      fail(node, path, "expected a whole number, got '" + node.Scalar() + "'");
    }
    if (value < lo || value > hi) {
      fail(node, path,
           "must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
               node.Scalar());
    }
    record(path, std::to_string(value));
    return value;
  }

  bool boolean(const YAML::Node& node, const std::string& path) const {
    bool value = false;
    if (!node.IsScalar() || !YAML::convert<bool>::decode(node, value)) {
      fail(node, path, "expected true or false");
    }
    record(path, value ? "true" : "false");
    return value;
  }

  std::string text(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar()) fail(node, path, "expected a text value");
    record(path, node.Scalar());
    return node.Scalar();
  }

  Eigen::Vector3d vector3(const YAML::Node& node, const std::string& path) const {
    if (!node.IsSequence() || node.size() != 3) fail(node, path, "expected a list [x, y, z]");
    Eigen::Vector3d v;
    for (std::size_t k = 0; k < 3; ++k)
      v[static_cast<Eigen::Index>(k)] = number(node[k], join(path, k));
    return v;
  }

  /// A velocity [m/s]: no input of a powder process moves anything near the speed of light, and
  /// the Hertz quantities of v^2 overflow beyond it.
  Eigen::Vector3d velocity(const YAML::Node& node, const std::string& path) const {
    Eigen::Vector3d v = vector3(node, path);
    if (!(v.stableNorm() < kSpeedOfLight)) {
      std::ostringstream what;
      what << "a speed of " << v.stableNorm()
           << " m/s is not physical (at or above the speed of light)";
      fail(node, path, what.str());
    }
    return v;
  }

  Eigen::Vector2d vector2(const YAML::Node& node, const std::string& path) const {
    if (!node.IsSequence() || node.size() != 2) fail(node, path, "expected a list [x, y]");
    Eigen::Vector2d v;
    for (std::size_t k = 0; k < 2; ++k)
      v[static_cast<Eigen::Index>(k)] = number(node[k], join(path, k));
    return v;
  }

  static std::string join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }
  static std::string join(const std::string& path, std::size_t index) {
    return join(path, std::to_string(index));
  }

  const std::string& source() const { return source_; }
  /// Whether @p path was given by --set.
  bool was_set(const std::string& path) const { return overrides_.count(path) != 0; }
  /// Every value read so far by the typed readers above, by path (Case::settings).
  const std::map<std::string, std::string>& settings() const { return settings_; }

 private:
  /// Note that @p path was read as @p value. Recording is what the typed readers do, not a step
  /// that a new key could forget: every value of the case passes through one of them.
  void record(const std::string& path, std::string value) const {
    settings_[path] = std::move(value);
  }

  std::string source_;
  std::map<std::string, std::string> overrides_;
  /// Mutable: the reader is passed as const everywhere; recording does not change what it reads.
  mutable std::map<std::string, std::string> settings_;
};

/// Split `a.b.0.c=value` and set that scalar in @p root. Only scalars (or new map keys, which
/// validation then checks like any other key) may be set.
void apply_override(YAML::Node& root, const std::string& assignment, const std::string& source,
                    std::map<std::string, std::string>& applied) {
  const auto equals = assignment.find('=');
  if (equals == std::string::npos || equals == 0) {
    throw CaseError("--set " + assignment + ": expected KEY=VALUE with a dotted key");
  }
  const std::string path = assignment.substr(0, equals);
  const std::string value = assignment.substr(equals + 1);
  const auto fail = [&](const std::string& what) -> void {
    throw CaseError("--set " + assignment + ": " + what + " (in " + source + ")");
  };
  // Split by hand: getline drops a trailing empty component, so `time.end.` would read as
  // `time.end` and `a.` as `a`.
  std::vector<std::string> parts;
  for (std::size_t begin = 0;;) {
    const std::size_t dot = path.find('.', begin);
    const std::string part = path.substr(begin, dot == std::string::npos ? dot : dot - begin);
    if (part.empty()) fail("empty component in key '" + path + "'");
    parts.push_back(part);
    if (dot == std::string::npos) break;
    begin = dot + 1;
  }
  YAML::Node node = root;
  std::string walked;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const std::string& part = parts[k];
    const bool last = k + 1 == parts.size();
    walked = Reader::join(walked, part);
    const YAML::Node& view = node;  // const lookups never insert keys into the tree
    std::size_t index = 0;
    if (node.IsSequence()) {
      // from_chars refuses what does not fit size_t, where stoul would throw its own message.
      const char* const end = part.data() + part.size();
      const auto [stop, error] = std::from_chars(part.data(), end, index);
      const bool is_index = error == std::errc() && stop == end;
      if (!is_index || index >= node.size()) {
        fail("'" + walked + "' is not an index of a list of " + std::to_string(node.size()));
      }
    } else if (!node.IsMap()) {
      fail("'" + walked + "' is inside a value that is not a mapping or a list");
    } else if (!view[part] && !last) {
      fail("the case has no key '" + walked + "'");
    }
    const YAML::Node child = node.IsSequence() ? view[index] : view[part];
    if (last) {
      if (child && !child.IsScalar()) fail("'" + walked + "' is not a single value");
      if (node.IsSequence()) {
        node[index] = value;
      } else {
        node[part] = value;
      }
    } else {
      node.reset(child);  // plain assignment would overwrite the tree, not move the cursor
    }
  }
  applied[path] = value;
}

BondCriterion criterion_from(const Reader& reader, const YAML::Node& node,
                             const std::string& path) {
  const std::string name = reader.text(node, path);
  if (name == "always") return BondCriterion::kAlways;
  if (name == "never") return BondCriterion::kNever;
  if (name == "temperature") return BondCriterion::kTemperature;
  reader.fail(node, path,
              "unknown criterion '" + name + "' (expected always, never or temperature)");
}

/// The one message for a key that only means something when temperatures are tracked.
[[noreturn]] void fail_without_thermal(const Reader& reader, const YAML::Node& node,
                                       const std::string& path) {
  reader.fail(node, path, "needs a thermal: block (without one no temperatures are tracked)");
}

/// Initial temperature of the particles of an entry with an optional `temperature` key: its own
/// value, else the thermal block's initial temperature, else the ParticleSpec default.
double particle_temperature(const Reader& reader, const Case& c, const YAML::Node& body,
                            const std::string& path) {
  const YAML::Node temperature = body["temperature"];
  if (!temperature) return c.thermal ? c.thermal->initial_temperature : ParticleSpec{}.temperature;
  if (!c.thermal) fail_without_thermal(reader, temperature, path + ".temperature");
  return reader.positive(temperature, path + ".temperature");
}

/// Held temperature of a wall (`temperature` key), or 0 (adiabatic) when it has none.
double wall_temperature(const Reader& reader, const Case& c, const YAML::Node& body,
                        const std::string& path) {
  const YAML::Node temperature = body["temperature"];
  if (!temperature) return 0.0;
  if (!c.thermal) fail_without_thermal(reader, temperature, path + ".temperature");
  return reader.positive(temperature, path + ".temperature");
}

ThermalModel read_thermal(const Reader& reader, const YAML::Node& node) {
  const std::string path = "thermal";
  reader.expect_map(node, path);
  reader.check_keys(
      node, path,
      {"initial_temperature", "ambient_temperature", "convection_coefficient", "radiation"});
  ThermalModel t;
  if (const YAML::Node initial = node["initial_temperature"]) {
    t.initial_temperature = reader.positive(initial, path + ".initial_temperature");
  }
  if (const YAML::Node ambient = node["ambient_temperature"]) {
    t.ambient_temperature = reader.positive(ambient, path + ".ambient_temperature");
  }
  if (const YAML::Node h = node["convection_coefficient"]) {
    t.convection_coefficient = reader.non_negative(h, path + ".convection_coefficient");
  }
  if (const YAML::Node radiation = node["radiation"]) {
    t.radiation = reader.boolean(radiation, path + ".radiation");
  }
  return t;
}

Laser read_laser(const Reader& reader, const YAML::Node& node) {
  const std::string path = "laser";
  reader.expect_map(node, path);
  reader.check_keys(node, path, {"power", "spot_radius", "absorptivity", "start_time", "path"});
  Laser laser{};
  laser.power = reader.non_negative(reader.require(node, path, "power"), path + ".power");
  laser.spot_radius =
      reader.positive(reader.require(node, path, "spot_radius"), path + ".spot_radius");
  laser.absorptivity =
      reader.fraction(reader.require(node, path, "absorptivity"), path + ".absorptivity");
  if (const YAML::Node start = node["start_time"]) {
    laser.start_time = reader.non_negative(start, path + ".start_time");
  }
  const std::string list_path = path + ".path";
  const YAML::Node segments = reader.require(node, path, "path");
  if (!segments.IsSequence()) {
    reader.fail(segments, list_path,
                "expected a list of segments {from: [x, y], to: [x, y], speed: v}");
  }
  if (segments.size() == 0) reader.fail(segments, list_path, "needs at least one segment");
  for (std::size_t k = 0; k < segments.size(); ++k) {
    const YAML::Node segment = segments[k];
    const std::string segment_path = Reader::join(list_path, k);
    reader.expect_map(segment, segment_path);
    reader.check_keys(segment, segment_path, {"from", "to", "speed"});
    LaserSegment s;
    s.start = reader.vector2(reader.require(segment, segment_path, "from"), segment_path + ".from");
    s.end = reader.vector2(reader.require(segment, segment_path, "to"), segment_path + ".to");
    s.speed =
        reader.positive(reader.require(segment, segment_path, "speed"), segment_path + ".speed");
    laser.path.push_back(s);
  }
  return laser;
}

/// Index of the material whose name is the value of @p name (at @p path).
int material_named(const Reader& reader, const Case& c, const YAML::Node& name,
                   const std::string& path) {
  const std::string text = reader.text(name, path);
  const auto found = std::find_if(c.materials.begin(), c.materials.end(),
                                  [&](const Material& m) { return m.name == text; });
  if (found == c.materials.end()) reader.fail(name, path, "no material named '" + text + "'");
  return static_cast<int>(found - c.materials.begin());
}

int material_index(const Reader& reader, const Case& c, const YAML::Node& body,
                   const std::string& path) {
  return material_named(reader, c, reader.require(body, path, "material"), path + ".material");
}

Box read_box(const Reader& reader, const YAML::Node& node, const std::string& path,
             bool allow_flat = false) {
  reader.expect_map(node, path);
  reader.check_keys(node, path, {"min", "max"});
  Box box;
  box.min = reader.vector3(reader.require(node, path, "min"), path + ".min");
  const YAML::Node max = reader.require(node, path, "max");
  box.max = reader.vector3(max, path + ".max");
  if (allow_flat) {
    if (!(box.max.array() >= box.min.array()).all()) {
      reader.fail(max, path + ".max", "must not be below min on any axis");
    }
  } else if (!(box.max.array() > box.min.array()).all()) {
    reader.fail(max, path + ".max", "must exceed min on every axis");
  }
  return box;
}

Domain read_domain(const Reader& reader, const YAML::Node& node, const std::string& path) {
  reader.expect_map(node, path);
  reader.check_keys(node, path, {"min", "max", "periodic", "remove_outside"});
  Domain d;
  d.min = reader.vector3(reader.require(node, path, "min"), path + ".min");
  const YAML::Node max = reader.require(node, path, "max");
  d.max = reader.vector3(max, path + ".max");
  if (!(d.max.array() > d.min.array()).all()) {
    reader.fail(max, path + ".max", "must exceed min on every axis");
  }
  if (const YAML::Node periodic = node["periodic"]) {
    if (!periodic.IsSequence() || periodic.size() != 3) {
      reader.fail(periodic, path + ".periodic", "expected a list of three booleans [x, y, z]");
    }
    for (std::size_t a = 0; a < 3; ++a) {
      d.periodic[a] = reader.boolean(periodic[a], Reader::join(path + ".periodic", a));
    }
  }
  if (const YAML::Node remove = node["remove_outside"]) {
    d.remove_outside = reader.boolean(remove, path + ".remove_outside");
  }
  return d;
}

/// A boundary's shape and the point its motion carries, as one reader entry reads them.
struct PlacedShape {
  BoundaryShapes shape;
  Eigen::Vector3d center;
};

/// `plane`: {point, normal}.
PlacedShape read_plane(const Reader& reader, const YAML::Node& node, const std::string& path) {
  const Eigen::Vector3d point =
      reader.vector3(reader.require(node, path, "point"), path + ".point");
  const YAML::Node normal_node = reader.require(node, path, "normal");
  Eigen::Vector3d normal = reader.vector3(normal_node, path + ".normal");
  if (!(normal.norm() > 0.0)) reader.fail(normal_node, path + ".normal", "must not be zero");
  normal.normalize();
  return {PlaneShape{normal}, point};
}

/// `blade`: a box {min, max}, carried by its centre.
PlacedShape read_blade(const Reader& reader, const YAML::Node& node, const std::string& path) {
  const Eigen::Vector3d lo = reader.vector3(reader.require(node, path, "min"), path + ".min");
  const YAML::Node max = reader.require(node, path, "max");
  const Eigen::Vector3d hi = reader.vector3(max, path + ".max");
  if (!(hi.array() > lo.array()).all()) reader.fail(max, path + ".max", "must exceed min");
  return {BoxShape{0.5 * (hi - lo)}, 0.5 * (lo + hi)};
}

/// `roller`: a cylinder through `point` along `axis` (default y) of `radius`; its `spin` is read
/// with the motion.
PlacedShape read_roller(const Reader& reader, const YAML::Node& node, const std::string& path) {
  CylinderShape roller;
  const Eigen::Vector3d point =
      reader.vector3(reader.require(node, path, "point"), path + ".point");
  if (const YAML::Node axis = node["axis"]) {
    roller.axis = reader.vector3(axis, path + ".axis");
    if (!(roller.axis.norm() > 0.0)) reader.fail(axis, path + ".axis", "must not be zero");
    roller.axis.normalize();
  }
  roller.radius = reader.positive(reader.require(node, path, "radius"), path + ".radius");
  return {roller, point};
}

/// `sphere`: {center, radius}.
PlacedShape read_sphere(const Reader& reader, const YAML::Node& node, const std::string& path) {
  const Eigen::Vector3d center =
      reader.vector3(reader.require(node, path, "center"), path + ".center");
  const double radius = reader.positive(reader.require(node, path, "radius"), path + ".radius");
  return {SphereShape{radius}, center};
}

/// `mesh`: an STL `file` (relative to the case file), each vertex x placed at scale * x + offset;
/// the reference point `center` defaults to the offset (the file's origin).
PlacedShape read_mesh(const Reader& reader, const YAML::Node& node, const std::string& path) {
  const YAML::Node file_node = reader.require(node, path, "file");
  const std::filesystem::path file = reader.text(file_node, path + ".file");
  const std::filesystem::path resolved =
      file.is_absolute() ? file : std::filesystem::path(reader.source()).parent_path() / file;
  const double scale = node["scale"] ? reader.positive(node["scale"], path + ".scale") : 1.0;
  const Eigen::Vector3d offset =
      node["offset"] ? reader.vector3(node["offset"], path + ".offset") : Eigen::Vector3d::Zero();
  const Eigen::Vector3d center =
      node["center"] ? reader.vector3(node["center"], path + ".center") : offset;
  StlMesh stl;
  try {
    stl = read_stl(resolved, scale, offset);
  } catch (const StlError& error) {
    reader.fail(file_node, path + ".file", error.what());
  }
  // Vertices relative to the reference point: the boundary frame.
  for (Eigen::Vector3d& v : stl.mesh.vertices) v -= center;
  // Cells of the mesh's own scale serve the reader's overlap checks; build_scene rebuilds the
  // grid for the particles' size.
  return {MeshShape{make_mesh_surface(std::move(stl.mesh), 0.0, file.string())}, center};
}

/// One entry per boundary shape: its case-file type, its own keys (besides type, material,
/// motion, name and temperature) and its reader.
struct ShapeReader {
  std::string type;
  std::vector<std::string> keys;
  PlacedShape (*read)(const Reader&, const YAML::Node&, const std::string&);
};

const std::vector<ShapeReader>& shape_readers() {
  static const std::vector<ShapeReader> readers{
      {"plane", {"point", "normal"}, read_plane},
      {"blade", {"min", "max"}, read_blade},
      {"roller", {"point", "axis", "radius", "spin"}, read_roller},
      {"sphere", {"center", "radius"}, read_sphere},
      {"mesh", {"file", "scale", "offset", "center"}, read_mesh},
  };
  return readers;
}

/// The reader entry of boundary type @p type, or nullptr when there is none.
const ShapeReader* find_shape_reader(const std::string& type) {
  for (const ShapeReader& entry : shape_readers()) {
    if (entry.type == type) return &entry;
  }
  return nullptr;
}

/// The keys of a motion table at @p node (a list).
std::vector<MotionKey> read_motion_keys(const Reader& reader, const YAML::Node& node,
                                        const std::string& path) {
  if (!node.IsSequence()) reader.fail(node, path, "expected a list of keys");
  std::vector<MotionKey> keys;
  for (std::size_t k = 0; k < node.size(); ++k) {
    const std::string key_path = Reader::join(path, k);
    reader.expect_map(node[k], key_path);
    reader.check_keys(node[k], key_path, {"time", "velocity", "angular_velocity"});
    MotionKey key;
    const YAML::Node time = reader.require(node[k], key_path, "time");
    key.time = reader.non_negative(time, key_path + ".time");
    if (!keys.empty() && key.time <= keys.back().time) {
      reader.fail(time, key_path + ".time", "motion keys must be in increasing time");
    }
    if (const YAML::Node velocity = node[k]["velocity"]) {
      key.velocity = reader.velocity(velocity, key_path + ".velocity");
    }
    if (const YAML::Node rate = node[k]["angular_velocity"]) {
      key.angular_velocity = reader.number(rate, key_path + ".angular_velocity");
    }
    keys.push_back(key);
  }
  return keys;
}

/// `motion`: a list of keys (a step profile), or a mapping {keys, interpolation: constant |
/// linear, axis, spin}; a roller's `spin` key is a constant spin about its own axis. The rotation
/// axis defaults to a roller's axis and is required for other shapes that turn.
Motion read_motion(const Reader& reader, const YAML::Node& node, const std::string& path,
                   const BoundaryShapes& shape) {
  Motion motion;
  const auto* cylinder = std::get_if<CylinderShape>(&shape);
  if (cylinder != nullptr) motion.axis = cylinder->axis;
  YAML::Node axis_node;
  bool axis_given = false;
  if (const YAML::Node spin = node["spin"]) motion.spin = reader.number(spin, path + ".spin");
  const std::string motion_path = path + ".motion";
  if (const YAML::Node m = node["motion"]) {
    if (m.IsSequence()) {
      motion.keys = read_motion_keys(reader, m, motion_path);
    } else {
      reader.expect_map(m, motion_path);
      reader.check_keys(m, motion_path, {"keys", "interpolation", "axis", "spin"});
      if (const YAML::Node keys = m["keys"]) {
        motion.keys = read_motion_keys(reader, keys, motion_path + ".keys");
      }
      if (const YAML::Node interpolation = m["interpolation"]) {
        const std::string kind = reader.text(interpolation, motion_path + ".interpolation");
        if (kind == "linear") {
          motion.interpolation = MotionInterpolation::kLinear;
        } else if (kind != "constant") {
          reader.fail(interpolation, motion_path + ".interpolation",
                      "unknown interpolation '" + kind + "' (constant or linear)");
        }
      }
      if (m["axis"]) {
        axis_node = m["axis"];
        axis_given = true;
        motion.axis = reader.vector3(axis_node, motion_path + ".axis");
        if (!(motion.axis.norm() > 0.0)) {
          reader.fail(axis_node, motion_path + ".axis", "must not be zero");
        }
        motion.axis.normalize();
      }
      if (const YAML::Node spin = m["spin"]) {
        motion.spin += reader.number(spin, motion_path + ".spin");
      }
    }
  }
  if (motion.rotates()) {
    const YAML::Node where = node["motion"] ? node["motion"] : node["spin"];
    if (std::holds_alternative<PlaneShape>(shape)) {
      reader.fail(where, motion_path, "a plane cannot rotate (it is unbounded)");
    }
    if (cylinder != nullptr && motion.axis.cross(cylinder->axis).norm() > 1e-12) {
      reader.fail(axis_given ? axis_node : where, motion_path + ".axis",
                  "a roller can only rotate about its own axis");
    }
    if (cylinder == nullptr && !axis_given) {
      reader.fail(where, motion_path,
                  "a rotation needs an axis: give the motion as {keys: [...], axis: [x, y, z]}");
    }
  }
  return motion;
}

/// A boundary: its shape's keys (shape_readers()) and `material`, `motion`, `name`,
/// `temperature`.
Boundary read_boundary(const Reader& reader, const Case& c, const YAML::Node& node,
                       const std::string& path, const ShapeReader& kind) {
  std::vector<std::string> keys{"type"};
  keys.insert(keys.end(), kind.keys.begin(), kind.keys.end());
  keys.insert(keys.end(), {"material", "motion", "name", "temperature"});
  reader.check_keys(node, path, keys);
  Boundary boundary;
  PlacedShape placed = kind.read(reader, node, path);
  boundary.shape = std::move(placed.shape);
  boundary.center = placed.center;
  boundary.material = material_index(reader, c, node, path);
  boundary.name = node["name"] ? reader.text(node["name"], path + ".name") : path;
  boundary.temperature = wall_temperature(reader, c, node, path);
  boundary.motion = read_motion(reader, node, path, boundary.shape);
  return boundary;
}

void read_walls(const Reader& reader, Case& c, const YAML::Node& walls) {
  if (!walls.IsSequence()) reader.fail(walls, "walls", "expected a list of walls");
  for (std::size_t k = 0; k < walls.size(); ++k) {
    const YAML::Node node = walls[k];
    const std::string path = Reader::join("walls", k);
    reader.expect_map(node, path);
    const YAML::Node type = reader.require(node, path, "type");
    const std::string kind = reader.text(type, path + ".type");
    if (kind == "box") {
      reader.check_keys(
          node, path, {"type", "min", "max", "material", "open", "name", "temperature", "motion"});
      const Eigen::Vector3d lo = reader.vector3(reader.require(node, path, "min"), path + ".min");
      const Eigen::Vector3d hi = reader.vector3(reader.require(node, path, "max"), path + ".max");
      if (!(hi.array() > lo.array()).all()) {
        reader.fail(node["max"], path + ".max", "must exceed min on every axis");
      }
      bool open[6] = {false, false, false, false, false, false};
      if (const YAML::Node faces = node["open"]) {
        if (!faces.IsSequence()) reader.fail(faces, path + ".open", "expected a list of faces");
        for (std::size_t f = 0; f < faces.size(); ++f) {
          const std::string face = reader.text(faces[f], Reader::join(path + ".open", f));
          const auto* end = kBoxFaceNames + 6;
          const auto* hit =
              std::find_if(kBoxFaceNames, end, [&](const char* name) { return face == name; });
          if (hit == end) {
            reader.fail(faces[f], Reader::join(path + ".open", f),
                        "unknown face '" + face + "' (x_min, x_max, y_min, y_max, z_min, z_max)");
          }
          open[hit - kBoxFaceNames] = true;
        }
      }
      const std::string name = node["name"] ? reader.text(node["name"], path + ".name") : path;
      const double temperature = wall_temperature(reader, c, node, path);
      // The faces move together; each is a plane, which may only translate.
      const Motion motion = read_motion(reader, node, path, PlaneShape{});
      for (Boundary& face :
           box_container(lo, hi, material_index(reader, c, node, path), open, name)) {
        face.temperature = temperature;
        face.motion = motion;
        c.boundaries.push_back(std::move(face));
      }
    } else if (const ShapeReader* shape = find_shape_reader(kind)) {
      c.boundaries.push_back(read_boundary(reader, c, node, path, *shape));
    } else {
      std::string message = "unknown wall type '" + kind + "' (box";
      const std::vector<ShapeReader>& shapes = shape_readers();
      for (std::size_t t = 0; t < shapes.size(); ++t) {
        message += t + 1 == shapes.size() ? " or " : ", ";
        message += shapes[t].type;
      }
      reader.fail(type, path + ".type", message + ")");
    }
  }
}

RadiusDistribution read_radius(const Reader& reader, const YAML::Node& node,
                               const std::string& path) {
  RadiusDistribution d;
  if (node.IsScalar()) {
    d.value = reader.positive(node, path);
    return d;
  }
  reader.expect_map(node, path);
  const YAML::Node kind_node = reader.require(node, path, "distribution");
  const std::string kind = reader.text(kind_node, path + ".distribution");
  const auto get = [&](const char* key, bool required) {
    const YAML::Node value = node[key];
    if (!value) {
      if (required) reader.fail(node, Reader::join(path, key), "missing required key");
      return 0.0;
    }
    return reader.positive(value, Reader::join(path, key));
  };
  if (kind == "constant") {
    reader.check_keys(node, path, {"distribution", "value"});
    d.value = get("value", true);
  } else if (kind == "uniform") {
    reader.check_keys(node, path, {"distribution", "min", "max"});
    d.kind = RadiusDistribution::Kind::kUniform;
    d.min = get("min", true);
    d.max = get("max", true);
  } else if (kind == "normal") {
    reader.check_keys(node, path, {"distribution", "mean", "std_dev", "min", "max"});
    d.kind = RadiusDistribution::Kind::kNormal;
    d.mean = get("mean", true);
    d.std_dev = get("std_dev", true);
    d.min = get("min", false);
    d.max = get("max", false);
  } else if (kind == "lognormal") {
    reader.check_keys(
        node, path,
        {"distribution", "median", "sigma", "d10", "d50", "d90", "weighting", "min", "max"});
    d.kind = RadiusDistribution::Kind::kLogNormal;
    if (node["d50"]) {
      // Measured particle diameters D10 < D50 < D90, by volume (laser diffraction, sieving: the
      // default) or by number.
      if (node["median"] || node["sigma"]) {
        reader.fail(node, path, "give either median and sigma or d10, d50 and d90");
      }
      const double d10 = get("d10", true);
      const double d50 = get("d50", true);
      const double d90 = get("d90", true);
      if (!(d10 < d50 && d50 < d90)) reader.fail(node, path, "needs d10 < d50 < d90");
      SizeWeighting weighting = SizeWeighting::kVolume;
      if (const YAML::Node weight = node["weighting"]) {
        const std::string name = reader.text(weight, path + ".weighting");
        if (name == "number") {
          weighting = SizeWeighting::kNumber;
        } else if (name != "volume") {
          reader.fail(weight, path + ".weighting",
                      "unknown weighting '" + name + "' (volume or number)");
        }
      }
      const RadiusDistribution fitted = lognormal_from_d_values(d10, d50, d90, weighting);
      d.median = fitted.median;
      d.sigma = fitted.sigma;
    } else {
      if (const YAML::Node weight = node["weighting"]) {
        reader.fail(weight, path + ".weighting",
                    "only with d10, d50 and d90 (median and sigma are of the radii drawn, by "
                    "number)");
      }
      d.median = get("median", true);
      d.sigma = get("sigma", true);
    }
    d.min = get("min", false);
    d.max = get("max", false);
  } else {
    reader.fail(kind_node, path + ".distribution",
                "unknown distribution '" + kind + "' (constant, uniform, normal, lognormal)");
  }
  try {
    validate(d);
  } catch (const std::invalid_argument& e) {
    reader.fail(node, path, e.what());
  }
  return d;
}

void check_inside(const Reader& reader, const Case& c, const ParticleSpec& p,
                  const YAML::Node& node, const std::string& path,
                  double allowed_overlap_fraction = 0.0) {
  if (c.domain) {
    for (int a = 0; a < 3; ++a) {
      if (p.position[a] < c.domain->min[a] || p.position[a] > c.domain->max[a]) {
        reader.fail(node, path + ".position", "lies outside the domain");
      }
    }
  }
  for (const Boundary& boundary : c.boundaries) {
    if (overlaps(boundary, p.position, p.radius * (1.0 - allowed_overlap_fraction))) {
      reader.fail(node, path,
                  (is_plane(boundary) ? "overlaps wall '" : "overlaps '") + boundary.name + "'" +
                      (allowed_overlap_fraction > 0.0
                           ? " by more than limits.max_overlap_fraction of its radius"
                           : ""));
    }
  }
}

/// Where the particles of one `particles.k` or `insert.k` entry start in Case::particles.
struct ParticleEntry {
  std::size_t first = 0;
  std::string key;
  YAML::Node node;
};

/// The entry that particle @p index came from: @p entries are in order of `first`.
const ParticleEntry& entry_of(const std::vector<ParticleEntry>& entries, std::size_t index) {
  const auto after =
      std::upper_bound(entries.begin(), entries.end(), index,
                       [](std::size_t i, const ParticleEntry& entry) { return i < entry.first; });
  return *(after - 1);
}

/// One check over every initial particle, explicit or inserted, across entries and periodic
/// boundaries: an overlap deeper than the run's own limit would stop the run at its first step.
void check_initial_overlaps(const Reader& reader, const Case& c,
                            const std::vector<ParticleEntry>& entries) {
  const std::optional<InitialOverlap> overlap =
      find_initial_overlap(c.particles, c.domain ? &*c.domain : nullptr, c.max_overlap_fraction);
  if (!overlap) return;
  const ParticleEntry& later = entry_of(entries, overlap->later);
  const ParticleEntry& earlier = entry_of(entries, overlap->earlier);
  const bool inserted = later.key.rfind("insert.", 0) == 0;
  std::string what;
  if (inserted) {
    const Eigen::Vector3d x = c.particles[overlap->later].position;
    what = "its particle at [" + message_number(x.x()) + ", " + message_number(x.y()) + ", " +
           message_number(x.z()) + "] ";
  }
  what += "overlaps " + (&later == &earlier ? "another particle of " + earlier.key : earlier.key);
  if (overlap->across_boundary) what += " across the periodic boundary";
  what += " by " + message_number(overlap->fraction) +
          " of the smaller radius, more than limits.max_overlap_fraction = " +
          message_number(c.max_overlap_fraction) + " allows (the run would stop at its first step)";
  reader.fail(later.node, later.key, what);
}

/// A periodic axis needs three neighbor cells of 2 * largest radius + skin (NeighborList).
void check_periodic_axes(const Reader& reader, const Case& c, const YAML::Node& root) {
  const double max_radius = largest_radius(c);
  if (!c.domain || max_radius == 0.0) return;
  const double skin = verlet_skin(c, max_radius);
  const double cell = 2.0 * max_radius + skin;
  const Eigen::Vector3d length = c.domain->length();
  for (int a = 0; a < 3; ++a) {
    if (!c.domain->periodic[a] || std::floor(length[a] / cell) >= 3.0) continue;
    std::string what = std::string("periodic axis ") + "xyz"[a] + " of length " +
                       message_number(length[a]) + " m is shorter than three neighbor cells of " +
                       message_number(cell) + " m (largest diameter " +
                       message_number(2.0 * max_radius) + " m + skin " + message_number(skin) +
                       " m)";
    if (c.skin > 0.0) {  // given, in the file or by --set
      const YAML::Node skin_node = root["neighbors"]["skin"];
      const double room = length[a] / 3.0 - 2.0 * max_radius;
      reader.fail(skin_node, "neighbors.skin",
                  what + (room > 0.0 ? "; the skin must be below " + message_number(room) + " m"
                                     : "; enlarge the domain"));
    }
    reader.fail(root["domain"]["periodic"], "domain.periodic", what + "; enlarge the domain");
  }
}

/// Index of the material named @p name in @p c, for a particle of an initial state; refuses a
/// name the case does not define.
int initial_material(const Reader& reader, const Case& c, const YAML::Node& node,
                     const std::string& where, std::string_view name) {
  for (std::size_t m = 0; m < c.materials.size(); ++m) {
    if (c.materials[m].name == name) return static_cast<int>(m);
  }
  reader.fail(node, "initial_state.file",
              where + ": material '" + std::string(name) +
                  "' is not among this case's materials (define it under `materials:`)");
}

/// The particles of a final-state file (final_state.csv or last_good_state.csv) at @p path.
std::vector<ParticleSpec> read_state_csv(const Reader& reader, const Case& c,
                                         const YAML::Node& node, const std::string& path) {
  std::ifstream in(path);
  if (!in) reader.fail(node, "initial_state.file", "cannot open '" + path + "'");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  {
    std::istringstream names(line);
    for (std::string name; std::getline(names, name, ',');) header.push_back(name);
  }
  const auto column = [&](std::string_view name) {
    const auto found = std::find(header.begin(), header.end(), name);
    return found == header.end() ? -1 : static_cast<int>(found - header.begin());
  };
  std::array<int, 9> required{};
  const char* const kRequired[9] = {"id", "x", "y", "z", "vx", "vy", "vz", "radius", "material"};
  for (int k = 0; k < 9; ++k) {
    required[k] = column(kRequired[k]);
    if (required[k] < 0) {
      reader.fail(node, "initial_state.file",
                  path + ": no column '" + kRequired[k] +
                      "' (a final_state.csv of this bondem version has id, x, y, z, vx, vy, "
                      "vz, radius, material, wx, wy, wz)");
    }
  }
  const std::array<int, 3> spin{column("wx"), column("wy"), column("wz")};
  const int temperature = c.thermal ? column("temperature") : -1;
  std::vector<ParticleSpec> particles;
  std::vector<std::string> fields;
  for (std::size_t line_number = 2; std::getline(in, line); ++line_number) {
    if (line.empty()) continue;
    const std::string where = path + ":" + std::to_string(line_number);
    fields.clear();
    std::istringstream row(line);
    for (std::string field; std::getline(row, field, ',');) fields.push_back(field);
    if (fields.size() != header.size()) {
      reader.fail(node, "initial_state.file",
                  where + ": " + std::to_string(fields.size()) + " values, the header has " +
                      std::to_string(header.size()));
    }
    const auto number = [&](int k) {
      double value = 0.0;
      const std::string& text = fields[static_cast<std::size_t>(k)];
      const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
      if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) {
        reader.fail(node, "initial_state.file",
                    where + ": '" + header[static_cast<std::size_t>(k)] + "' is '" + text +
                        "', not a finite number");
      }
      return value;
    };
    ParticleSpec p;
    const double id = number(required[0]);
    if (id < 0.0 || id != std::floor(id) || id > 9.0e15) {
      reader.fail(node, "initial_state.file", where + ": id must be a whole number >= 0");
    }
    p.id = static_cast<std::int64_t>(id);
    for (int a = 0; a < 3; ++a) {
      p.position[a] = number(required[1 + a]);
      p.velocity[a] = number(required[4 + a]);
      if (spin[a] >= 0) p.angular_velocity[a] = number(spin[a]);
    }
    p.radius = number(required[7]);
    if (!(p.radius > 0.0)) reader.fail(node, "initial_state.file", where + ": radius must be > 0");
    p.material =
        initial_material(reader, c, node, where, fields[static_cast<std::size_t>(required[8])]);
    p.temperature = temperature >= 0 ? number(temperature)
                    : c.thermal      ? c.thermal->initial_temperature
                                     : ParticleSpec{}.temperature;
    particles.push_back(p);
  }
  return particles;
}

/// The particles of a checkpoint at @p path, and its pairs' springs and bonds into @p c.
std::vector<ParticleSpec> read_state_checkpoint(const Reader& reader, Case& c,
                                                const YAML::Node& node, const std::string& path) {
  Checkpoint state;
  try {
    state = read_checkpoint(path);
  } catch (const CheckpointError& e) {
    reader.fail(node, "initial_state.file", e.what());
  }
  const Particles& p = state.particles;
  std::vector<int> material(state.material_names.size());
  for (std::size_t m = 0; m < material.size(); ++m) {
    material[m] = initial_material(reader, c, node, path, state.material_names[m]);
  }
  std::vector<ParticleSpec> particles(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    ParticleSpec& s = particles[i];
    const auto m = static_cast<std::size_t>(p.material[i]);
    if (m >= material.size()) {
      reader.fail(node, "initial_state.file", path + ": a particle's material has no name");
    }
    s.material = material[m];
    s.id = p.id[i];
    s.radius = p.radius[i];
    s.position = {p.x[i], p.y[i], p.z[i]};
    s.velocity = {p.vx[i], p.vy[i], p.vz[i]};
    s.angular_velocity = {p.wx[i], p.wy[i], p.wz[i]};
    s.temperature = c.thermal ? (p.thermal() ? p.temperature[i] : c.thermal->initial_temperature)
                              : ParticleSpec{}.temperature;
  }
  c.initial_pairs = std::move(state.stepper.slips);
  return particles;
}

/// `initial_state: {file: PATH}`: the particles of another run's final_state.csv or checkpoint,
/// appended to @p c's particles, periodic coordinates wrapped into the domain.
void read_initial_state(const Reader& reader, const YAML::Node& root, Case& c,
                        std::vector<ParticleEntry>& entries) {
  const YAML::Node state = root["initial_state"];
  if (!state) return;
  reader.expect_map(state, "initial_state");
  reader.check_keys(state, "initial_state", {"file"});
  const YAML::Node file = reader.require(state, "initial_state", "file");
  const std::string path = reader.text(file, "initial_state.file");
  const bool csv = path.size() >= 4 && path.compare(path.size() - 4, 4, ".csv") == 0;
  std::vector<ParticleSpec> particles =
      csv ? read_state_csv(reader, c, file, path) : read_state_checkpoint(reader, c, file, path);
  if (particles.empty()) reader.fail(file, "initial_state.file", path + " holds no particle");
  std::vector<std::int64_t> ids;
  for (ParticleSpec& p : particles) {
    ids.push_back(p.id);
    if (!c.domain) continue;
    for (int a = 0; a < 3; ++a) {
      if (c.domain->periodic[a]) {
        p.position[a] =
            wrap_periodic(p.position[a], c.domain->min[a], c.domain->max[a] - c.domain->min[a]);
      }
    }
  }
  std::sort(ids.begin(), ids.end());
  if (const auto twice = std::adjacent_find(ids.begin(), ids.end()); twice != ids.end()) {
    reader.fail(file, "initial_state.file", path + ": id " + std::to_string(*twice) + " twice");
  }
  entries.push_back({c.particles.size(), "initial_state", state});
  for (const ParticleSpec& p : particles) {
    // A particle resting on a wall overlaps it a little, as it does its neighbors.
    check_inside(reader, c, p, state, "initial_state (id " + std::to_string(p.id) + ")",
                 c.max_overlap_fraction);
    c.particles.push_back(p);
  }
}

/// An `insert:` entry of type `stream` (the caller has read its type).
StreamInsertion read_stream(const Reader& reader, const Case& c, const YAML::Node& body,
                            const std::string& path) {
  reader.check_keys(body, path,
                    {"type", "region", "material", "radius", "rate", "mass_rate", "start", "end",
                     "velocity", "seed", "max_attempts", "temperature"});
  if (!c.domain) {
    reader.fail(body, path, "a stream needs a `domain:` (the grid its particles are added to)");
  }
  StreamInsertion s;
  const YAML::Node region = reader.require(body, path, "region");
  s.region = read_box(reader, region, path + ".region", /*allow_flat=*/true);
  s.material = material_index(reader, c, body, path);
  const YAML::Node radius = reader.require(body, path, "radius");
  s.radius = read_radius(reader, radius, path + ".radius");
  const double largest = largest_radius(s.radius);
  if (!(largest > 0.0) || !(smallest_radius(s.radius) > 0.0)) {
    reader.fail(radius, path + ".radius",
                "a stream's radii need both bounds (min and max cut-offs of a normal or "
                "log-normal distribution), so that the neighbor grid and the time step allow "
                "for its largest and smallest particle");
  }
  static constexpr const char* kAxis[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    if (s.region.min[a] < c.domain->min[a] || s.region.max[a] > c.domain->max[a]) {
      reader.fail(region, path + ".region",
                  std::string("reaches outside the domain along ") + kAxis[a]);
    }
    const double extent = s.region.max[a] - s.region.min[a];
    if (extent > 0.0 && extent < 2.0 * largest) {
      reader.fail(region, path + ".region",
                  std::string("is ") + message_number(extent) + " m along " + kAxis[a] +
                      ", less than the largest diameter " + message_number(2.0 * largest) +
                      " m (make it 0 for a face, or wider)");
    }
  }
  const YAML::Node rate = body["rate"];
  const YAML::Node mass_rate = body["mass_rate"];
  if ((rate && mass_rate) || (!rate && !mass_rate)) {
    reader.fail(body, path, "give exactly one of rate (particles/s) and mass_rate (kg/s)");
  }
  if (rate) s.particle_rate = reader.positive(rate, path + ".rate");
  if (mass_rate) s.mass_rate = reader.positive(mass_rate, path + ".mass_rate");
  if (const YAML::Node start = body["start"]) {
    s.start_time = reader.non_negative(start, path + ".start");
  }
  s.end_time = c.end_time;
  if (const YAML::Node end = body["end"]) s.end_time = reader.positive(end, path + ".end");
  if (!(s.end_time > s.start_time)) {
    reader.fail(body["end"] ? body["end"] : body, path + ".end",
                "ends at " + message_number(s.end_time) + " s, not after its start " +
                    message_number(s.start_time) + " s");
  }
  if (const YAML::Node v = body["velocity"]) s.velocity = reader.velocity(v, path + ".velocity");
  if (const YAML::Node seed = body["seed"]) {
    s.seed = static_cast<std::uint64_t>(reader.integer(seed, path + ".seed", 0, 1LL << 62));
  }
  if (const YAML::Node attempts = body["max_attempts"]) {
    s.max_attempts =
        static_cast<std::size_t>(reader.integer(attempts, path + ".max_attempts", 1, 1000000));
  }
  s.temperature = particle_temperature(reader, c, body, path);
  return s;
}

void read_insertions(const Reader& reader, Case& c, const YAML::Node& insert,
                     std::vector<ParticleEntry>& entries) {
  if (!insert.IsSequence()) reader.fail(insert, "insert", "expected a list of insertions");
  for (std::size_t k = 0; k < insert.size(); ++k) {
    const YAML::Node body = insert[k];
    const std::string path = Reader::join("insert", k);
    reader.expect_map(body, path);
    const YAML::Node type = reader.require(body, path, "type");
    const std::string kind = reader.text(type, path + ".type");
    std::vector<ParticleSpec> added;
    std::optional<LatticeBlock> lattice;  // kept as a block: it stores no particle
    Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
    try {
      if (kind == "lattice") {
        reader.check_keys(
            body, path,
            {"type", "region", "spacing", "radius", "material", "velocity", "temperature"});
        const Box region = read_box(reader, reader.require(body, path, "region"), path + ".region");
        const double spacing =
            reader.positive(reader.require(body, path, "spacing"), path + ".spacing");
        const double radius =
            reader.positive(reader.require(body, path, "radius"), path + ".radius");
        // Counts and the lattice's own overlap are known before a single particle is made.
        const std::array<double, 3> counts = lattice_counts(region, spacing, radius);
        const YAML::Node spacing_node = body["spacing"];
        const double total = counts[0] * counts[1] * counts[2];
        if (!(total <= kMaxInsertedParticles)) {
          reader.fail(spacing_node, path + ".spacing",
                      "gives " + message_number(counts[0]) + " x " + message_number(counts[1]) +
                          " x " + message_number(counts[2]) + " = " + message_number(total) +
                          " particles, more than the limit of " +
                          message_number(kMaxInsertedParticles) + " per insertion");
        }
        const double overlap = (2.0 * radius - spacing) / radius;
        if (std::max({counts[0], counts[1], counts[2]}) > 1.0 && overlap > c.max_overlap_fraction) {
          reader.fail(spacing_node, path + ".spacing",
                      "neighbors of the lattice overlap by " + message_number(overlap) +
                          " of their radius, more than limits.max_overlap_fraction = " +
                          message_number(c.max_overlap_fraction) +
                          " allows (the run would stop at its first step)");
        }
        lattice = lattice_block(region, spacing, radius, material_index(reader, c, body, path));
      } else if (kind == "random") {
        reader.check_keys(body, path,
                          {"type", "region", "material", "count", "solid_fraction", "radius",
                           "seed", "velocity", "max_attempts", "temperature"});
        FillRequest request;
        request.region = read_box(reader, reader.require(body, path, "region"), path + ".region");
        request.material = material_index(reader, c, body, path);
        request.radius =
            read_radius(reader, reader.require(body, path, "radius"), path + ".radius");
        const YAML::Node count = body["count"];
        const YAML::Node fraction = body["solid_fraction"];
        if ((count && fraction) || (!count && !fraction)) {
          reader.fail(body, path, "give exactly one of count and solid_fraction");
        }
        if (count)
          request.count =
              static_cast<std::size_t>(reader.integer(count, path + ".count", 1, 100000000));
        if (fraction) {
          request.solid_fraction = reader.positive(fraction, path + ".solid_fraction");
        }
        if (const YAML::Node seed = body["seed"]) {
          request.seed =
              static_cast<std::uint64_t>(reader.integer(seed, path + ".seed", 0, 1LL << 62));
        }
        if (const YAML::Node attempts = body["max_attempts"]) {
          request.max_attempts_per_particle = static_cast<std::size_t>(
              reader.integer(attempts, path + ".max_attempts", 1, 100000000));
        }
        added = insert_random_fill(request, c.particles);
      } else if (kind == "stream") {
        c.streams.push_back(read_stream(reader, c, body, path));
        continue;
      } else {
        reader.fail(type, path + ".type",
                    "unknown insertion '" + kind + "' (lattice, random or stream)");
      }
    } catch (const CaseError&) {
      throw;
    } catch (const std::exception& e) {
      reader.fail(body, path, e.what());
    }
    if (const YAML::Node v = body["velocity"]) velocity = reader.velocity(v, path + ".velocity");
    const double temperature = particle_temperature(reader, c, body, path);
    if (!added.empty() || (lattice && lattice->size() > 0)) {
      entries.push_back({c.particles.size(), path, body});
    }
    for (ParticleSpec& p : added) {
      p.velocity = velocity;
      p.temperature = temperature;
      check_inside(reader, c, p, body, path);
    }
    if (lattice) {
      lattice->velocity = velocity;
      lattice->temperature = temperature;
      for (std::size_t i = 0; i < lattice->size(); ++i) {
        check_inside(reader, c, lattice->at(i), body, path);
      }
      c.particles.append(*lattice);
    }
    c.particles.append(std::move(added));
  }
}

/// `materials:`: names (each once, plain) and elastic and thermal properties.
void read_materials(const Reader& reader, const YAML::Node& root, Case& c) {
  const YAML::Node materials = reader.require(root, "", "materials");
  reader.expect_map(materials, "materials");
  if (materials.size() == 0) reader.fail(materials, "materials", "at least one material needed");
  for (const auto& entry : materials) {
    // yaml-cpp keeps both entries of a repeated key (lookups see only the first) and turns a
    // non-scalar key into an empty name: both would silently define the wrong material.
    const YAML::Node& key = entry.first;
    if (!key.IsScalar() || key.Scalar().empty()) {
      reader.fail(key, "materials", "a material's name must be a plain, non-empty name");
    }
    Material m;
    m.name = key.Scalar();
    const std::string path = Reader::join("materials", m.name);
    if (std::any_of(c.materials.begin(), c.materials.end(),
                    [&](const Material& known) { return known.name == m.name; })) {
      reader.fail(key, path, "material defined twice");
    }
    const YAML::Node& body = entry.second;
    reader.expect_map(body, path);
    reader.check_keys(body, path,
                      {"density", "youngs_modulus", "poisson_ratio", "specific_heat",
                       "thermal_conductivity", "emissivity"});
    // Bounds far outside any solid (osmium: 2.3e4 kg/m^3, diamond: 1.2e12 Pa) but inside what the
    // derived quantities (masses, stiffnesses, their products) can hold in a double.
    const YAML::Node density = reader.require(body, path, "density");
    m.density = reader.positive(density, path + ".density");
    if (m.density > 1e6) reader.fail(density, path + ".density", "must not exceed 1e6 kg/m^3");
    const YAML::Node modulus = reader.require(body, path, "youngs_modulus");
    m.youngs_modulus = reader.positive(modulus, path + ".youngs_modulus");
    if (m.youngs_modulus > 1e14) {
      reader.fail(modulus, path + ".youngs_modulus", "must not exceed 1e14 Pa");
    }
    const YAML::Node nu = reader.require(body, path, "poisson_ratio");
    m.poisson_ratio = reader.number(nu, path + ".poisson_ratio");
    if (!(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5)) {
      reader.fail(nu, path + ".poisson_ratio", "must lie in (-1, 0.5), got " + nu.Scalar());
    }
    // Thermal properties may be given without a thermal block (a shared material list); they are
    // then unused. Whether c_p is needed is checked once the particles are known.
    if (const YAML::Node cp = body["specific_heat"]) {
      m.specific_heat = reader.positive(cp, path + ".specific_heat");
    }
    if (const YAML::Node k = body["thermal_conductivity"]) {
      m.thermal_conductivity = reader.non_negative(k, path + ".thermal_conductivity");
    }
    if (const YAML::Node emissivity = body["emissivity"]) {
      m.emissivity = reader.fraction(emissivity, path + ".emissivity");
    }
    c.materials.push_back(m);
  }
}

/// The keys of a contact model: `contact:` holds them all (and the run-wide normal law), an
/// `interactions:` entry any of them.
const std::vector<std::string>& contact_model_keys() {
  static const std::vector<std::string> keys = {
      "restitution",   "damping_ratio",   "friction", "rolling_friction",
      "rolling_model", "rolling_damping", "cohesion"};
  return keys;
}

/// `cohesion: {model: none | sjkr {energy_density} | jkr {surface_energy}}` at @p path.
void read_cohesion(const Reader& reader, const Case& c, const YAML::Node& node,
                   const std::string& path, ContactModel& model) {
  reader.expect_map(node, path);
  reader.check_keys(node, path, {"model", "energy_density", "surface_energy"});
  const YAML::Node name = reader.require(node, path, "model");
  const std::string kind = reader.text(name, path + ".model");
  const YAML::Node density = node["energy_density"];
  const YAML::Node energy = node["surface_energy"];
  const auto refuse = [&](const YAML::Node& key, const std::string& key_name) {
    if (key) {
      reader.fail(key, path + "." + key_name,
                  "does not belong to cohesion model " + kind +
                      " (sjkr takes energy_density, jkr surface_energy, none neither)");
    }
  };
  if (kind == "none") {
    refuse(density, "energy_density");
    refuse(energy, "surface_energy");
    model.cohesion = CohesionModel::kNone;
    model.cohesion_energy = 0.0;
  } else if (kind == "sjkr") {
    refuse(energy, "surface_energy");
    model.cohesion = CohesionModel::kSjkr;
    model.cohesion_energy =
        reader.positive(reader.require(node, path, "energy_density"), path + ".energy_density");
  } else if (kind == "jkr") {
    refuse(density, "energy_density");
    if (std::holds_alternative<HookeLawSpec>(c.normal_law)) {
      reader.fail(name, path + ".model",
                  "jkr is a Hertz-based theory: it needs the hertz normal law, not hooke");
    }
    model.cohesion = CohesionModel::kJkr;
    model.cohesion_energy =
        reader.positive(reader.require(node, path, "surface_energy"), path + ".surface_energy");
  } else {
    reader.fail(name, path + ".model",
                "unknown cohesion model '" + kind + "' (expected none, sjkr or jkr)");
  }
}

/// The contact-model keys of @p node (at @p path) over @p model: `contact:` itself when
/// @p defaults (then exactly one of restitution and damping_ratio is required), else an
/// `interactions:` entry, whose keys override the defaults it starts from.
void read_contact_model(const Reader& reader, const Case& c, const YAML::Node& node,
                        const std::string& path, bool defaults, ContactModel& model) {
  const YAML::Node restitution = node["restitution"];
  const YAML::Node damping = node["damping_ratio"];
  if (restitution && damping) {
    reader.fail(damping, path + ".damping_ratio",
                "give either restitution or damping_ratio, not both (one sets the other)");
  }
  if (defaults && !restitution && !damping) {
    reader.fail(node, path + ".restitution",
                "missing required key (restitution or damping_ratio: the contact damping)");
  }
  if (damping) {
    model.damping_ratio = reader.non_negative(damping, path + ".damping_ratio");
    model.restitution = 0.0;
  }
  if (restitution) {
    const double e = reader.number(restitution, path + ".restitution");
    if (!(e > 0.0 && e <= 1.0)) {
      reader.fail(restitution, path + ".restitution",
                  "must lie in (0, 1], got " + restitution.Scalar());
    }
    model.restitution = e;
    model.damping_ratio = 0.0;
  }
  if (const YAML::Node mu = node["friction"]) {
    model.friction = reader.non_negative(mu, path + ".friction");
  }
  if (const YAML::Node mu_r = node["rolling_friction"]) {
    model.rolling_friction = reader.non_negative(mu_r, path + ".rolling_friction");
  }
  if (const YAML::Node rolling = node["rolling_model"]) {
    const std::string name = reader.text(rolling, path + ".rolling_model");
    if (name == "constant_torque") {
      model.rolling_model = RollingModel::kConstantTorque;
    } else if (name == "epsd") {
      model.rolling_model = RollingModel::kEpsd;
    } else {
      reader.fail(rolling, path + ".rolling_model",
                  "unknown rolling model '" + name + "' (expected constant_torque or epsd)");
    }
  }
  if (const YAML::Node eta = node["rolling_damping"]) {
    if (model.rolling_model != RollingModel::kEpsd) {
      reader.fail(eta, path + ".rolling_damping",
                  "only with rolling_model epsd (constant_torque has no rolling damper)");
    }
    model.rolling_damping = reader.non_negative(eta, path + ".rolling_damping");
  }
  if (const YAML::Node cohesion = node["cohesion"]) {
    read_cohesion(reader, c, cohesion, path + ".cohesion", model);
  }
}

/// `contact:`: the run-wide normal-force law and the contact model of every pair of materials.
/// The law is the Hertz (+ bond) law unless `normal_law: hooke`, which needs `stiffness` and has
/// no adhesion.
void read_contact(const Reader& reader, const YAML::Node& root, Case& c) {
  const YAML::Node contact = reader.require(root, "", "contact");
  reader.expect_map(contact, "contact");
  std::vector<std::string> keys = contact_model_keys();
  keys.insert(keys.begin(), {"normal_law", "stiffness"});
  reader.check_keys(contact, "contact", keys);
  const YAML::Node stiffness = contact["stiffness"];
  std::string law = "hertz";
  if (const YAML::Node name = contact["normal_law"]) {
    law = reader.text(name, "contact.normal_law");
    if (law != "hertz" && law != "hooke") {
      reader.fail(name, "contact.normal_law",
                  "unknown normal law '" + law + "' (expected hertz or hooke)");
    }
  }
  if (law == "hooke") {
    if (!stiffness) {
      reader.fail(contact, "contact.stiffness",
                  "missing required key (the spring stiffness of normal_law hooke)");
    }
    if (const YAML::Node bond = root["bond"]) {
      reader.fail(bond, "bond", "contact.normal_law hooke has no adhesion: a bond never forms");
    }
    c.normal_law = HookeLawSpec{reader.positive(stiffness, "contact.stiffness")};
  } else if (stiffness) {
    reader.fail(stiffness, "contact.stiffness",
                "only with normal_law hooke (the Hertz stiffness follows from the materials)");
  }
  read_contact_model(reader, c, contact, "contact", true, c.contact);
}

/// `limits:`: the overlap that stops a run (also the limit of the initial overlaps).
void read_limits(const Reader& reader, const YAML::Node& root, Case& c) {
  if (const YAML::Node limits = root["limits"]) {
    reader.expect_map(limits, "limits");
    reader.check_keys(limits, "limits", {"max_overlap_fraction"});
    const YAML::Node fraction = reader.require(limits, "limits", "max_overlap_fraction");
    c.max_overlap_fraction = reader.positive(fraction, "limits.max_overlap_fraction");
    if (c.max_overlap_fraction > 1.0) {
      reader.fail(fraction, "limits.max_overlap_fraction", "must not exceed 1 (a whole radius)");
    }
  }
}

/// The keys of a `bond:` block (or an interaction's) at @p path over @p bond. A complete block
/// (@p complete: the top-level one, or an interaction's over defaults without a bond) needs
/// alpha, a strength, damping_ratio and criterion; otherwise each key given overrides.
void read_bond_keys(const Reader& reader, const Case& c, const YAML::Node& node,
                    const std::string& path, bool complete, BondModel& bond) {
  reader.expect_map(node, path);
  reader.check_keys(
      node, path,
      {"alpha", "stiffness", "equilibrium_overlap", "damping_ratio", "criterion", "temperature"});
  const auto key = [&](const char* name) {
    return complete ? reader.require(node, path, name) : node[name];
  };
  if (const YAML::Node alpha = key("alpha")) {
    bond.alpha = reader.number(alpha, path + ".alpha");
    if (!(bond.alpha >= 0.0 && bond.alpha < 1.5)) {
      reader.fail(alpha, path + ".alpha",
                  "must lie in [0, 1.5): the bond is stable only while the contact exponent 3/2 "
                  "exceeds the adhesion exponent (eq. 9, 14), got " +
                      alpha.Scalar());
    }
  }
  const YAML::Node stiffness = node["stiffness"];
  const YAML::Node overlap = node["equilibrium_overlap"];
  if (stiffness && overlap) {
    reader.fail(overlap, path + ".equilibrium_overlap",
                "give either " + path + ".stiffness or " + path + ".equilibrium_overlap, not both");
  }
  if (complete && !stiffness && !overlap) {
    reader.fail(node, path, "needs " + path + ".stiffness or " + path + ".equilibrium_overlap");
  }
  if (stiffness) {
    bond.input = AdhesionInput::kStiffness;
    bond.stiffness = reader.positive(stiffness, path + ".stiffness");
  } else if (overlap) {
    bond.input = AdhesionInput::kEquilibriumOverlap;
    bond.equilibrium_overlap = reader.positive(overlap, path + ".equilibrium_overlap");
  }
  if (const YAML::Node damping = key("damping_ratio")) {
    bond.damping_ratio = reader.non_negative(damping, path + ".damping_ratio");
  }
  const YAML::Node criterion = key("criterion");
  if (criterion) bond.criterion = criterion_from(reader, criterion, path + ".criterion");
  const YAML::Node temperature = node["temperature"];
  if (bond.criterion == BondCriterion::kTemperature) {
    if (!c.thermal) fail_without_thermal(reader, criterion ? criterion : node, path + ".criterion");
    if (temperature) {
      bond.temperature = reader.positive(temperature, path + ".temperature");
    } else if (!(bond.temperature > 0.0)) {
      reader.fail(node, path + ".temperature",
                  "missing required key (the bonding temperature of criterion temperature)");
    }
  } else if (temperature) {
    reader.fail(temperature, path + ".temperature",
                "only with criterion temperature (the criterion is " +
                    std::string(criterion ? criterion.Scalar() : "not temperature") + ")");
  }
}

/// `bond:`, the paper's bond law of every pair of materials; without one, no pair bonds.
void read_bond(const Reader& reader, const YAML::Node& root, Case& c) {
  if (const YAML::Node bond = root["bond"]) {
    read_bond_keys(reader, c, bond, "bond", true, c.contact.bond);
  } else {
    // No bond block: no bond forms. delta_eq only has to be a valid number.
    c.contact.bond.criterion = BondCriterion::kNever;
    c.contact.bond.input = AdhesionInput::kEquilibriumOverlap;
    c.contact.bond.equilibrium_overlap = 1.0;
  }
}

/// `interactions:`: per pair of materials, contact-model and bond keys over the defaults.
void read_interactions(const Reader& reader, const YAML::Node& root, Case& c) {
  const YAML::Node list = root["interactions"];
  if (!list) return;
  if (!list.IsSequence()) reader.fail(list, "interactions", "expected a list of entries");
  for (std::size_t k = 0; k < list.size(); ++k) {
    const std::string path = Reader::join("interactions", k);
    const YAML::Node entry = list[k];
    reader.expect_map(entry, path);
    std::vector<std::string> keys = contact_model_keys();
    keys.insert(keys.begin(), {"materials", "bond"});
    reader.check_keys(entry, path, keys);
    const YAML::Node names = reader.require(entry, path, "materials");
    if (!names.IsSequence() || names.size() != 2) {
      reader.fail(names, path + ".materials", "expected a list of two material names");
    }
    Interaction interaction;
    interaction.first_material =
        material_named(reader, c, names[0], Reader::join(path + ".materials", 0));
    interaction.second_material =
        material_named(reader, c, names[1], Reader::join(path + ".materials", 1));
    for (const Interaction& before : c.interactions) {
      if (before.joins(interaction.first_material, interaction.second_material)) {
        reader.fail(names, path + ".materials", "this pair of materials is given twice");
      }
    }
    interaction.model = c.contact;
    read_contact_model(reader, c, entry, path, false, interaction.model);
    if (const YAML::Node bond = entry["bond"]) {
      if (std::holds_alternative<HookeLawSpec>(c.normal_law)) {
        reader.fail(bond, path + ".bond",
                    "contact.normal_law hooke has no adhesion: a bond never forms");
      }
      read_bond_keys(reader, c, bond, path + ".bond", !root["bond"], interaction.model.bond);
    }
    c.interactions.push_back(interaction);
  }
}

/// `time:`: step and end, and the step count within kMaxSteps.
void read_time(const Reader& reader, const YAML::Node& root, Case& c) {
  const YAML::Node time = reader.require(root, "", "time");
  reader.expect_map(time, "time");
  reader.check_keys(time, "time", {"step", "end"});
  c.time_step = reader.positive(reader.require(time, "time", "step"), "time.step");
  const YAML::Node end = reader.require(time, "time", "end");
  c.end_time = reader.positive(end, "time.end");
  if (c.end_time < c.time_step) reader.fail(end, "time.end", "is shorter than one time step");
  // Checked in double: the count of a long end and a tiny step fits no integer. Blamed on
  // time.step when only that was --set.
  if (const double steps = c.end_time / c.time_step; !(steps <= kMaxSteps)) {
    const YAML::Node step = time["step"];
    const bool blame_step = reader.was_set("time.step") && !reader.was_set("time.end");
    std::ostringstream what;
    what << "gives " << steps << " steps (time.end " << c.end_time << " s / time.step "
         << c.time_step << " s), more than the limit of " << kMaxSteps << " steps";
    reader.fail(blame_step ? step : end, blame_step ? "time.step" : "time.end", what.str());
  }
}

/// `particles:`, the explicit list; returns its node (an empty list when absent).
YAML::Node read_explicit_particles(const Reader& reader, const YAML::Node& root, Case& c) {
  const YAML::Node particles =
      root["particles"] ? root["particles"] : YAML::Node(YAML::NodeType::Sequence);
  if (!particles.IsSequence()) reader.fail(particles, "particles", "expected a list of particles");
  for (std::size_t k = 0; k < particles.size(); ++k) {
    const YAML::Node body = particles[k];
    const std::string path = Reader::join("particles", k);
    reader.expect_map(body, path);
    reader.check_keys(body, path, {"material", "radius", "position", "velocity", "temperature"});
    ParticleSpec spec;
    spec.material = material_index(reader, c, body, path);
    spec.radius = reader.positive(reader.require(body, path, "radius"), path + ".radius");
    spec.position = reader.vector3(reader.require(body, path, "position"), path + ".position");
    if (const YAML::Node velocity = body["velocity"]) {
      spec.velocity = reader.velocity(velocity, path + ".velocity");
    }
    spec.temperature = particle_temperature(reader, c, body, path);
    c.particles.push_back(spec);
  }

  return particles;
}

/// With a `thermal:` block every material that particles use needs a heat capacity.
void check_heat_capacities(const Reader& reader, const YAML::Node& root, Case& c) {
  if (c.thermal) {
    // m c_p dT/dt needs a heat capacity for every particle; walls only need a conductivity.
    for (std::size_t m = 0; m < c.materials.size(); ++m) {
      const Material& material = c.materials[m];
      if (material.specific_heat > 0.0) continue;
      const bool used =
          std::any_of(c.particles.begin(), c.particles.end(),
                      [&](const ParticleSpec& p) { return p.material == static_cast<int>(m); });
      if (used) {
        reader.fail(root["materials"][material.name],
                    Reader::join("materials", material.name) + ".specific_heat",
                    "missing required key: particles of material '" + material.name +
                        "' need it with a thermal: block");
      }
    }
  }
}

/// A bond whose equilibrium overlap the run's own overlap limit forbids would stop every run that
/// bonds: refuse delta_eq at or above limits.max_overlap_fraction of the smallest radius.
void check_equilibrium_overlap(const Reader& reader, const YAML::Node& root, const Case& c) {
  const double limit = c.max_overlap_fraction * smallest_radius(c);
  const auto check = [&](const BondModel& bond, const YAML::Node& node, const std::string& path) {
    if (bond.criterion == BondCriterion::kNever ||
        bond.input != AdhesionInput::kEquilibriumOverlap || bond.equilibrium_overlap < limit) {
      return;
    }
    std::ostringstream what;
    what << bond.equilibrium_overlap << " m is not below limits.max_overlap_fraction ("
         << c.max_overlap_fraction << ") of the smallest radius, " << limit
         << " m: a bonded pair would stop the run";
    reader.fail(node && node["equilibrium_overlap"] ? node["equilibrium_overlap"] : root,
                path + ".equilibrium_overlap", what.str());
  };
  check(c.contact.bond, root["bond"], "bond");
  for (std::size_t k = 0; k < c.interactions.size(); ++k) {
    const YAML::Node entry = root["interactions"][k];
    const std::string path = Reader::join("interactions", k) + ".bond";
    check(c.interactions[k].model.bond, entry["bond"] ? entry["bond"] : root["bond"], path);
  }
}

/// `neighbors:`: skin and reordering interval.
void read_neighbors(const Reader& reader, const YAML::Node& root, Case& c) {
  if (const YAML::Node neighbors = root["neighbors"]) {
    reader.expect_map(neighbors, "neighbors");
    reader.check_keys(neighbors, "neighbors", {"skin", "reorder_interval"});
    if (const YAML::Node skin = neighbors["skin"]) c.skin = reader.positive(skin, "neighbors.skin");
    if (const YAML::Node interval = neighbors["reorder_interval"]) {
      c.reorder_interval =
          static_cast<int>(reader.integer(interval, "neighbors.reorder_interval", 0, 1000000));
    }
  }
}

/// `output:`: directory and intervals.
void read_output(const Reader& reader, const YAML::Node& root, Case& c) {
  if (const YAML::Node output = root["output"]) {
    reader.expect_map(output, "output");
    reader.check_keys(output, "output",
                      {"directory", "history_interval", "checkpoint_interval", "vtk_interval",
                       "history_fields", "state_interval", "vtk_fields"});
    const YAML::Node directory = reader.require(output, "output", "directory");
    c.output_directory = reader.text(directory, "output.directory");
    if (c.output_directory.empty()) reader.fail(directory, "output.directory", "is empty");
    if (const YAML::Node interval = output["history_interval"]) {
      c.history_interval = reader.positive(interval, "output.history_interval");
    }
    if (const YAML::Node interval = output["vtk_interval"]) {
      c.vtk_interval = reader.positive(interval, "output.vtk_interval");
    }
    if (const YAML::Node interval = output["checkpoint_interval"]) {
      c.checkpoint_interval = reader.positive(interval, "output.checkpoint_interval");
    }
    if (const YAML::Node interval = output["state_interval"]) {
      c.state_interval = reader.positive(interval, "output.state_interval");
    }
    // The names are checked against the run's columns and arrays once its scene exists
    // (run_case), with the place they were read from.
    const auto names = [&](const char* key, std::vector<std::string>& list, std::string& origin) {
      const YAML::Node fields = output[key];
      if (!fields) return;
      const std::string path = std::string("output.") + key;
      if (!fields.IsSequence() || fields.size() == 0) {
        reader.fail(fields, path, "expected a non-empty list of names");
      }
      for (std::size_t k = 0; k < fields.size(); ++k) {
        const std::string name = reader.text(fields[k], Reader::join(path, k));
        if (std::find(list.begin(), list.end(), name) != list.end()) {
          reader.fail(fields[k], Reader::join(path, k), "'" + name + "' listed twice");
        }
        list.push_back(name);
      }
      origin = reader.origin(fields, path);
    };
    names("history_fields", c.history_fields, c.history_fields_origin);
    names("vtk_fields", c.vtk_fields, c.vtk_fields_origin);
    if (!c.vtk_fields.empty() && c.vtk_interval == 0.0) {
      reader.fail(output["vtk_fields"], "output.vtk_fields", "needs output.vtk_interval");
    }
  }
}

/// `analysis:`: the bed region and the spread layer, checked before step 0.
/// `analysis.layer`, or with @p series `analysis.layers`: the layer's box, bins and surface grid
/// (at most kMaxLayerColumns columns at the grid spacing, or at a quarter of @p radius_min by
/// default). A series also has `times` and an optional `platform`, read by its caller; with a
/// platform its substrate moves, so it has no `substrate_z`.
LayerRegion read_layer(const Reader& reader, const YAML::Node& layer, const Case& c,
                       double radius_min, bool series) {
  static constexpr const char* kAxis[3] = {"x", "y", "z"};
  const std::string path = series ? "analysis.layers" : "analysis.layer";
  reader.expect_map(layer, path);
  std::vector<std::string> keys = {"x_min",       "x_max",        "y_min", "y_max",
                                   "substrate_z", "layer_height", "bins",  "grid_spacing"};
  if (series) keys.insert(keys.end(), {"times", "platform"});
  reader.check_keys(layer, path, keys);
  const bool on_platform = series && layer["platform"];
  if (on_platform && layer["substrate_z"]) {
    reader.fail(layer["substrate_z"], path + ".substrate_z",
                "give substrate_z or platform, not both (a platform carries the substrate)");
  }
  LayerRegion r;
  r.x_min = reader.number(reader.require(layer, path, "x_min"), path + ".x_min");
  r.x_max = reader.number(reader.require(layer, path, "x_max"), path + ".x_max");
  r.y_min = reader.number(reader.require(layer, path, "y_min"), path + ".y_min");
  r.y_max = reader.number(reader.require(layer, path, "y_max"), path + ".y_max");
  if (!(r.x_max > r.x_min)) reader.fail(layer["x_max"], path + ".x_max", "must exceed x_min");
  if (!(r.y_max > r.y_min)) reader.fail(layer["y_max"], path + ".y_max", "must exceed y_min");
  if (!on_platform) {
    r.substrate_z =
        reader.number(reader.require(layer, path, "substrate_z"), path + ".substrate_z");
  }
  r.layer_height =
      reader.positive(reader.require(layer, path, "layer_height"), path + ".layer_height");
  if (const YAML::Node bins = layer["bins"]) {
    r.bins = static_cast<int>(reader.integer(bins, path + ".bins", 1, 100000));
  }
  if (const YAML::Node spacing = layer["grid_spacing"]) {
    r.grid_spacing = reader.positive(spacing, path + ".grid_spacing");
  }
  if (c.domain) {
    const double layer_min[3] = {r.x_min, r.y_min, r.substrate_z};
    const double layer_max[3] = {r.x_max, r.y_max, r.substrate_z + r.layer_height};
    const char* bound[3] = {"x_min", "y_min", "substrate_z"};
    for (int a = 0; a < (on_platform ? 2 : 3); ++a) {
      if (layer_max[a] <= c.domain->min[a] || layer_min[a] >= c.domain->max[a]) {
        reader.fail(layer[bound[a]], path + "." + bound[a],
                    std::string("the layer lies outside the domain along ") + kAxis[a]);
      }
    }
  }
  // The surface grid: its spacing, or by default a quarter of the smallest radius (a bound:
  // the run takes the smallest among the particles at the surface).
  const double spacing = r.grid_spacing > 0.0 ? r.grid_spacing : 0.25 * radius_min;
  const double columns = layer_grid_columns(r, spacing);
  if (columns > kMaxLayerColumns) {
    std::ostringstream what;
    what << "the surface grid would have " << columns << " columns (spacing " << spacing
         << " m), above " << kMaxLayerColumns;
    if (r.grid_spacing > 0.0) {
      reader.fail(layer["grid_spacing"], path + ".grid_spacing", what.str());
    }
    reader.fail(layer, path, what.str() + "; set a coarser grid_spacing");
  }
  return r;
}

/// `analysis.layers`: the layer box of read_layer, the increasing positive `times` at which layer
/// 1, 2, ... is measured (a time after time.end is not reached: a run shortened to try a case
/// measures fewer layers, and its restart with the end raised measures the rest), and the
/// `platform` the bed stands on (a boundary named so whose top is flat and level: a `blade` box
/// that does not turn, or a plane facing +z).
LayerSeries read_layer_series(const Reader& reader, const YAML::Node& layers, const Case& c,
                              double radius_min) {
  const std::string path = "analysis.layers";
  LayerSeries series;
  series.region = read_layer(reader, layers, c, radius_min, true);
  const YAML::Node times = reader.require(layers, path, "times");
  if (!times.IsSequence() || times.size() == 0) {
    reader.fail(times, path + ".times", "expected a non-empty list of times [s]");
  }
  for (std::size_t k = 0; k < times.size(); ++k) {
    const std::string at = Reader::join(path + ".times", k);
    const double t = reader.positive(times[k], at);
    if (!series.times.empty() && !(t > series.times.back())) {
      reader.fail(times[k], at, "the times must increase");
    }
    series.times.push_back(t);
  }
  if (const YAML::Node platform = layers["platform"]) {
    const std::string name = reader.text(platform, path + ".platform");
    const auto named = std::find_if(c.boundaries.begin(), c.boundaries.end(),
                                    [&](const Boundary& b) { return b.name == name; });
    if (named == c.boundaries.end()) {
      std::string names;
      for (const Boundary& b : c.boundaries) names += (names.empty() ? "" : ", ") + b.name;
      reader.fail(platform, path + ".platform",
                  "no boundary is named '" + name +
                      "' (the boundaries: " + (names.empty() ? "none" : names) + ")");
    }
    if (!has_level_top(*named)) {
      reader.fail(platform, path + ".platform",
                  "'" + name +
                      "' has no flat level top: a platform is a blade box that does not turn or "
                      "a plane whose normal is +z");
    }
    series.platform = static_cast<int>(named - c.boundaries.begin());
  }
  return series;
}

void read_analysis(const Reader& reader, const YAML::Node& root, Case& c) {
  if (const YAML::Node analysis = root["analysis"]) {
    reader.expect_map(analysis, "analysis");
    reader.check_keys(analysis, "analysis", {"region", "layer", "layers"});
    // Settings that could only fail after the last step are checked here, before step 0.
    static constexpr const char* kAxis[3] = {"x", "y", "z"};
    double radius_sum = 0.0;
    for (const ParticleSpec& p : c.particles) radius_sum += p.radius;
    // A stream's particles too: a layer of poured powder has its smallest spheres at the surface.
    const double radius_min = smallest_radius(c);
    if (const YAML::Node region = analysis["region"]) {
      c.analysis_region = read_box(reader, region, "analysis.region");
      const Box& box = *c.analysis_region;
      for (int a = 0; a < 3; ++a) {
        if (c.domain && (box.max[a] <= c.domain->min[a] || box.min[a] >= c.domain->max[a])) {
          reader.fail(region, "analysis.region",
                      std::string("lies outside the domain along ") + kAxis[a]);
        }
        const double mean_diameter =
            c.particles.empty() ? 0.0 : 2.0 * radius_sum / static_cast<double>(c.particles.size());
        if (box.max[a] - box.min[a] < kMinRegionDiameters * mean_diameter) {
          std::ostringstream what;
          what << "spans " << (box.max[a] - box.min[a]) / mean_diameter
               << " mean particle diameters along " << kAxis[a]
               << "; a solid fraction needs at least " << kMinRegionDiameters;
          reader.fail(region, "analysis.region", what.str());
        }
      }
    }
    if (const YAML::Node layer = analysis["layer"]) {
      c.layer = read_layer(reader, layer, c, radius_min, false);
    }
    if (const YAML::Node layers = analysis["layers"]) {
      c.layers = read_layer_series(reader, layers, c, radius_min);
    }
  }
}

Case read_case(const YAML::Node& root, const Reader& reader) {
  Case c;
  c.source = reader.source();
  if (!root || root.IsNull()) reader.fail(root, "", "the file is empty");
  reader.expect_map(root, "");
  reader.check_keys(root, "",
                    {"description", "materials", "contact", "bond", "interactions", "time",
                     "gravity", "particles", "initial_state", "insert", "domain", "walls",
                     "neighbors", "output", "analysis", "thermal", "laser", "limits"});

  read_materials(reader, root, c);
  read_contact(reader, root, c);
  // Before any particle: the initial-overlap checks use the run's limit.
  read_limits(reader, root, c);

  // Read first: whether temperatures are tracked decides which other keys are allowed.
  if (const YAML::Node thermal = root["thermal"]) c.thermal = read_thermal(reader, thermal);
  if (const YAML::Node laser = root["laser"]) {
    if (!c.thermal) fail_without_thermal(reader, laser, "laser");
    c.laser = read_laser(reader, laser);
  }

  read_bond(reader, root, c);
  read_interactions(reader, root, c);
  read_time(reader, root, c);
  if (const YAML::Node gravity = root["gravity"]) c.gravity = reader.vector3(gravity, "gravity");

  const YAML::Node particles = read_explicit_particles(reader, root, c);
  const std::size_t explicit_count = c.particles.size();
  std::vector<ParticleEntry> entries;
  for (std::size_t k = 0; k < explicit_count; ++k) {
    entries.push_back({k, Reader::join("particles", k), particles[k]});
  }
  if (const YAML::Node domain = root["domain"]) c.domain = read_domain(reader, domain, "domain");
  if (const YAML::Node walls = root["walls"]) read_walls(reader, c, walls);
  for (std::size_t k = 0; k < explicit_count; ++k) {
    check_inside(reader, c, c.particles[k], particles[k], Reader::join("particles", k));
  }
  read_initial_state(reader, root, c, entries);
  if (const YAML::Node insert = root["insert"]) read_insertions(reader, c, insert, entries);
  if (c.particles.empty() && c.streams.empty()) {
    reader.fail(root, "particles", "the case has no particles (and no stream inserts any)");
  }
  check_heat_capacities(reader, root, c);
  check_equilibrium_overlap(reader, root, c);

  read_neighbors(reader, root, c);
  check_periodic_axes(reader, c, root);
  check_initial_overlaps(reader, c, entries);

  read_output(reader, root, c);
  read_analysis(reader, root, c);
  c.settings = reader.settings();
  return c;
}

}  // namespace

Case parse_case(const std::string& text, const std::string& source,
                const std::vector<std::string>& overrides) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& error) {
    std::ostringstream message;
    message << source << ":" << error.mark.line + 1 << ":" << error.mark.column + 1
            << ": not valid YAML: " << error.msg;
    throw CaseError(message.str());
  }
  std::map<std::string, std::string> applied;
  for (const std::string& assignment : overrides) {
    if (!root.IsMap()) throw CaseError(source + ": --set needs a case that is a mapping");
    apply_override(root, assignment, source, applied);
  }
  try {
    return read_case(root, Reader(source, applied));
  } catch (const YAML::Exception& error) {
    // Anything the checks above did not anticipate still becomes a one-line error.
    std::ostringstream message;
    message << source << ":" << error.mark.line + 1 << ":" << error.mark.column + 1 << ": "
            << error.msg;
    throw CaseError(message.str());
  }
}

Case load_case(const std::string& path, const std::vector<std::string>& overrides) {
  std::ifstream file(path);
  if (!file) throw CaseError(path + ": cannot open the case file");
  std::stringstream buffer;
  buffer << file.rdbuf();
  return parse_case(buffer.str(), path, overrides);
}

}  // namespace bondem
