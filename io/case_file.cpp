#include "io/case_file.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

namespace bondem {
namespace {

/// Where a value came from, so that every message can point at it.
class Reader {
 public:
  Reader(std::string source, std::map<std::string, std::string> overrides)
      : source_(std::move(source)), overrides_(std::move(overrides)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& path,
                         const std::string& what) const {
    std::ostringstream message;
    const auto set = overrides_.find(path);
    if (set != overrides_.end()) {
      message << "--set " << path << "=" << set->second;
    } else {
      message << source_;
      const YAML::Mark mark = node.Mark();
      if (mark.line >= 0) message << ":" << mark.line + 1 << ":" << mark.column + 1;
    }
    message << ": " << (path.empty() ? "case" : "'" + path + "'") << ": " << what;
    throw CaseError(message.str());
  }

  void expect_map(const YAML::Node& node, const std::string& path) const {
    if (!node.IsMap()) fail(node, path, "expected a mapping of keys to values");
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

  std::string text(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar()) fail(node, path, "expected a text value");
    return node.Scalar();
  }

  Eigen::Vector3d vector3(const YAML::Node& node, const std::string& path) const {
    if (!node.IsSequence() || node.size() != 3) fail(node, path, "expected a list [x, y, z]");
    Eigen::Vector3d v;
    for (std::size_t k = 0; k < 3; ++k)
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

 private:
  std::string source_;
  std::map<std::string, std::string> overrides_;
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
  std::vector<std::string> parts;
  std::stringstream stream(path);
  for (std::string part; std::getline(stream, part, '.');) {
    if (part.empty()) fail("empty component in key '" + path + "'");
    parts.push_back(part);
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
      const bool is_index = std::all_of(part.begin(), part.end(), ::isdigit);
      if (is_index) index = std::stoul(part);
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
  reader.fail(node, path, "unknown criterion '" + name + "' (expected always or never)");
}

Case read_case(const YAML::Node& root, const Reader& reader) {
  Case c;
  c.source = reader.source();
  if (!root || root.IsNull()) reader.fail(root, "", "the file is empty");
  reader.expect_map(root, "");
  reader.check_keys(
      root, "",
      {"description", "materials", "contact", "bond", "time", "gravity", "particles", "output"});

  const YAML::Node materials = reader.require(root, "", "materials");
  reader.expect_map(materials, "materials");
  if (materials.size() == 0) reader.fail(materials, "materials", "at least one material needed");
  for (const auto& entry : materials) {
    Material m;
    m.name = entry.first.Scalar();
    const std::string path = Reader::join("materials", m.name);
    const YAML::Node& body = entry.second;
    reader.expect_map(body, path);
    reader.check_keys(body, path, {"density", "youngs_modulus", "poisson_ratio"});
    m.density = reader.positive(reader.require(body, path, "density"), path + ".density");
    m.youngs_modulus =
        reader.positive(reader.require(body, path, "youngs_modulus"), path + ".youngs_modulus");
    const YAML::Node nu = reader.require(body, path, "poisson_ratio");
    m.poisson_ratio = reader.number(nu, path + ".poisson_ratio");
    if (!(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5)) {
      reader.fail(nu, path + ".poisson_ratio", "must lie in (-1, 0.5), got " + nu.Scalar());
    }
    c.materials.push_back(m);
  }

  const YAML::Node contact = reader.require(root, "", "contact");
  reader.expect_map(contact, "contact");
  reader.check_keys(contact, "contact", {"damping_ratio"});
  c.contact_damping = reader.non_negative(reader.require(contact, "contact", "damping_ratio"),
                                          "contact.damping_ratio");

  if (const YAML::Node bond = root["bond"]) {
    reader.expect_map(bond, "bond");
    reader.check_keys(bond, "bond",
                      {"alpha", "stiffness", "equilibrium_overlap", "damping_ratio", "criterion"});
    const YAML::Node alpha = reader.require(bond, "bond", "alpha");
    c.bond.alpha = reader.number(alpha, "bond.alpha");
    if (!(c.bond.alpha >= 0.0 && c.bond.alpha < 1.5)) {
      reader.fail(alpha, "bond.alpha",
                  "must lie in [0, 1.5): the bond is stable only while the contact exponent 3/2 "
                  "exceeds the adhesion exponent (eq. 9, 14), got " +
                      alpha.Scalar());
    }
    const YAML::Node stiffness = bond["stiffness"];
    const YAML::Node overlap = bond["equilibrium_overlap"];
    if (stiffness && overlap) {
      reader.fail(overlap, "bond.equilibrium_overlap",
                  "give either bond.stiffness or bond.equilibrium_overlap, not both");
    }
    if (!stiffness && !overlap) {
      reader.fail(bond, "bond", "needs bond.stiffness or bond.equilibrium_overlap");
    }
    if (stiffness) {
      c.bond.input = AdhesionInput::kStiffness;
      c.bond.stiffness = reader.positive(stiffness, "bond.stiffness");
    } else {
      c.bond.input = AdhesionInput::kEquilibriumOverlap;
      c.bond.equilibrium_overlap = reader.positive(overlap, "bond.equilibrium_overlap");
    }
    c.bond.damping_ratio =
        reader.non_negative(reader.require(bond, "bond", "damping_ratio"), "bond.damping_ratio");
    c.bond.criterion =
        criterion_from(reader, reader.require(bond, "bond", "criterion"), "bond.criterion");
  } else {
    // No bond block: plain damped Hertz. delta_eq only has to be a valid number.
    c.bond.criterion = BondCriterion::kNever;
    c.bond.input = AdhesionInput::kEquilibriumOverlap;
    c.bond.equilibrium_overlap = 1.0;
  }

  const YAML::Node time = reader.require(root, "", "time");
  reader.expect_map(time, "time");
  reader.check_keys(time, "time", {"step", "end"});
  c.time_step = reader.positive(reader.require(time, "time", "step"), "time.step");
  const YAML::Node end = reader.require(time, "time", "end");
  c.end_time = reader.positive(end, "time.end");
  if (c.end_time < c.time_step) reader.fail(end, "time.end", "is shorter than one time step");

  if (const YAML::Node gravity = root["gravity"]) c.gravity = reader.vector3(gravity, "gravity");

  const YAML::Node particles = reader.require(root, "", "particles");
  if (!particles.IsSequence()) reader.fail(particles, "particles", "expected a list of particles");
  for (std::size_t k = 0; k < particles.size(); ++k) {
    const YAML::Node body = particles[k];
    const std::string path = Reader::join("particles", k);
    reader.expect_map(body, path);
    reader.check_keys(body, path, {"material", "radius", "position", "velocity"});
    ParticleSpec spec;
    const YAML::Node material = reader.require(body, path, "material");
    const std::string name = reader.text(material, path + ".material");
    const auto found = std::find_if(c.materials.begin(), c.materials.end(),
                                    [&](const Material& m) { return m.name == name; });
    if (found == c.materials.end()) {
      reader.fail(material, path + ".material", "no material named '" + name + "'");
    }
    spec.material = static_cast<int>(found - c.materials.begin());
    spec.radius = reader.positive(reader.require(body, path, "radius"), path + ".radius");
    spec.position = reader.vector3(reader.require(body, path, "position"), path + ".position");
    if (const YAML::Node velocity = body["velocity"]) {
      spec.velocity = reader.vector3(velocity, path + ".velocity");
    }
    c.particles.push_back(spec);
  }

  if (const YAML::Node output = root["output"]) {
    reader.expect_map(output, "output");
    reader.check_keys(output, "output", {"directory"});
    const YAML::Node directory = reader.require(output, "output", "directory");
    c.output_directory = reader.text(directory, "output.directory");
    if (c.output_directory.empty()) reader.fail(directory, "output.directory", "is empty");
  }
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
