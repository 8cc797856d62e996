#include "io/checkpoint.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <type_traits>
#include <variant>

#include "io/atomic_file.hpp"

namespace bondem {
namespace {

constexpr char kMagic[8] = {'B', 'O', 'N', 'D', 'E', 'M', 'C', 'K'};

/// FNV-1a, 64 bit: simple, dependency-free, and enough to catch truncation and bit rot.
std::uint64_t fnv1a(const char* data, std::size_t size,
                    std::uint64_t hash = 0xcbf29ce484222325ULL) {
  for (std::size_t k = 0; k < size; ++k) {
    hash ^= static_cast<unsigned char>(data[k]);
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

class Writer {
 public:
  template <class T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* bytes = reinterpret_cast<const char*>(&value);
    buffer_.append(bytes, sizeof(T));
  }
  template <class T>
  void put(const std::vector<T>& values) {
    put(static_cast<std::uint64_t>(values.size()));
    buffer_.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  }
  void put(const std::string& text) {
    put(static_cast<std::uint64_t>(text.size()));
    buffer_.append(text);
  }
  const std::string& bytes() const { return buffer_; }

 private:
  std::string buffer_;
};

class Reader {
 public:
  Reader(const std::string& bytes, std::string path) : bytes_(bytes), path_(std::move(path)) {}
  template <class T>
  T get() {
    T value;
    take(&value, sizeof(T));
    return value;
  }
  template <class T>
  void get(std::vector<T>& values, std::uint64_t expected) {
    const auto size = get<std::uint64_t>();
    if (size != expected)
      fail("array of " + std::to_string(size) + " entries, expected " + std::to_string(expected));
    check_room(size, sizeof(T));
    values.resize(size);
    take(values.data(), size * sizeof(T));
  }
  std::string get_text() {
    const auto size = get<std::uint64_t>();
    if (size > bytes_.size() - offset_) fail("truncated text");
    std::string text = bytes_.substr(offset_, size);
    offset_ += size;
    return text;
  }
  void get_raw(void* out, std::size_t size) { take(out, size); }
  /// Refuse a count of @p count entries of @p entry_size bytes that the bytes left cannot hold:
  /// checked before allocating, so a forged count cannot exhaust memory.
  void check_room(std::uint64_t count, std::size_t entry_size) const {
    if (count > (bytes_.size() - offset_) / entry_size) {
      fail("array of " + std::to_string(count) + " entries, more than the file holds");
    }
  }
  bool at_end() const { return offset_ == bytes_.size(); }
  [[noreturn]] void fail(const std::string& what) const {
    throw CheckpointError(path_ + ": corrupt checkpoint: " + what);
  }

 private:
  void take(void* out, std::size_t size) {
    if (size > bytes_.size() - offset_) fail("truncated");
    if (size == 0) return;  // an empty vector's data() may be null, which memcpy must not get
    std::memcpy(out, bytes_.data() + offset_, size);
    offset_ += size;
  }
  const std::string& bytes_;
  std::string path_;
  std::size_t offset_ = 0;
};

}  // namespace

std::uint64_t case_fingerprint(const Case& c) {
  std::ostringstream text;
  text.precision(17);
  for (const Material& m : c.materials) {
    text << m.name << ' ' << m.density << ' ' << m.youngs_modulus << ' ' << m.poisson_ratio << ';';
  }
  text << c.contact_damping << ' ' << c.friction << ' ' << c.rolling_friction << ';' << c.bond.alpha
       << ' ' << static_cast<int>(c.bond.input) << ' ' << c.bond.stiffness << ' '
       << c.bond.equilibrium_overlap << ' ' << c.bond.damping_ratio << ' '
       << static_cast<int>(c.bond.criterion) << ';' << c.time_step << ';' << c.gravity.transpose()
       << ';' << c.particles.size() << ';' << c.skin << ' ' << c.reorder_interval << ' '
       << c.max_overlap_fraction << ';';
  if (c.domain) {
    text << c.domain->min.transpose() << ' ' << c.domain->max.transpose() << ' '
         << c.domain->periodic[0] << c.domain->periodic[1] << c.domain->periodic[2] << ';';
  }
  for (const PlaneWall& w : c.walls) {
    text << w.point.transpose() << ' ' << w.normal.transpose() << ' ' << w.material << ';';
  }
  for (const Body& b : c.bodies) {
    text << static_cast<int>(b.shape) << ' ' << b.center.transpose() << ' '
         << b.half_size.transpose() << ' ' << b.axis.transpose() << ' ' << b.radius << ' ' << b.spin
         << ' ' << b.material << ';';
    for (const MotionKey& key : b.motion)
      text << key.time << ' ' << key.velocity.transpose() << ';';
  }
  // Thermal settings only enter with a thermal block (nothing thermal acts without one), so the
  // fingerprints of other cases, and the checkpoints that carry them, stay as they were.
  if (c.thermal) {
    const ThermalModel& t = *c.thermal;
    text << "thermal " << t.initial_temperature << ' ' << t.ambient_temperature << ' '
         << t.convection_coefficient << ' ' << t.radiation << ' ' << c.bond.temperature << ';';
    for (const Material& m : c.materials) {
      text << m.specific_heat << ' ' << m.thermal_conductivity << ' ' << m.emissivity << ';';
    }
    for (const PlaneWall& w : c.walls) text << w.temperature << ';';
    if (c.laser) {
      const Laser& l = *c.laser;
      text << "laser " << l.power << ' ' << l.spot_radius << ' ' << l.absorptivity << ' '
           << l.start_time << ';';
      for (const LaserSegment& s : l.path) {
        text << s.start.transpose() << ' ' << s.end.transpose() << ' ' << s.speed << ';';
      }
    }
  }
  const std::string canonical = text.str();
  return fnv1a(canonical.data(), canonical.size());
}

void write_checkpoint(const std::string& path, const Checkpoint& checkpoint) {
  Writer payload;
  const Particles& p = checkpoint.particles;
  const StepperState& s = checkpoint.stepper;
  payload.put(checkpoint.case_fingerprint);
  payload.put(s.time);
  payload.put(s.step);
  payload.put(static_cast<std::uint64_t>(s.contacts.contacts));
  payload.put(static_cast<std::uint64_t>(s.contacts.bonds));
  payload.put(static_cast<std::uint64_t>(s.contacts.wall_contacts));
  payload.put(s.contacts.max_overlap);
  payload.put(s.contacts.max_overlap_fraction);
  payload.put(s.list.builds);
  payload.put(static_cast<std::uint64_t>(p.size()));
  const auto put_section = [&](CheckpointSection section) {
    for (const ParticleField& field : kParticleFields) {
      if (has(field, kCheckpointed) && checkpoint_section(field) == section) {
        std::visit([&](auto member) { payload.put(p.*member); }, field.member);
      }
    }
  };
  put_section(CheckpointSection::kParticle);
  for (const auto* field : {&s.list.x0, &s.list.y0, &s.list.z0}) payload.put(*field);
  payload.put(static_cast<std::int32_t>(p.walls));
  put_section(CheckpointSection::kWall);
  // Field by field: the struct's padding bytes are not part of the state.
  payload.put(static_cast<std::uint64_t>(s.slips.size()));
  for (const SlipRecord& slip : s.slips) {
    payload.put(slip.first_id);
    payload.put(slip.second_id);
    for (const double v : {slip.sx, slip.sy, slip.sz}) payload.put(v);
    payload.put(slip.bonded);
  }
  payload.put(s.bodies);
  payload.put(s.bonds_formed);
  payload.put(s.bonds_broken);
  payload.put(s.laser_energy);
  payload.put(s.laser_missed);
  // Thermal arrays, one value per particle, only in thermal runs.
  payload.put(static_cast<std::uint8_t>(p.thermal() ? 1 : 0));
  if (p.thermal()) put_section(CheckpointSection::kThermal);
  payload.put(checkpoint.history);

  AtomicFile file(path, std::ios::binary);
  std::ostream& out = file.stream();
  const std::string& bytes = payload.bytes();
  out.write(kMagic, sizeof kMagic);
  const std::uint32_t version = kCheckpointVersion;
  const std::uint64_t size = bytes.size();
  const std::uint64_t checksum = fnv1a(bytes.data(), bytes.size());
  out.write(reinterpret_cast<const char*>(&version), sizeof version);
  out.write(reinterpret_cast<const char*>(&size), sizeof size);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.write(reinterpret_cast<const char*>(&checksum), sizeof checksum);
  file.commit();
}

Checkpoint read_checkpoint(const std::string& path) {
  // A directory opens as a stream on Linux and reports an absurd size: refuse it by its type.
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (error || !std::filesystem::exists(status)) {
    throw CheckpointError(path + ": cannot open the checkpoint (no such file)");
  }
  if (!std::filesystem::is_regular_file(status)) {
    throw CheckpointError(path + ": not a checkpoint file (a directory or other special file)");
  }
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw CheckpointError(path + ": cannot open the checkpoint");
  const std::streamoff length = in.tellg();
  if (length < 0) throw CheckpointError(path + ": cannot read the checkpoint");
  std::string file(static_cast<std::size_t>(length), '\0');
  in.seekg(0);
  in.read(file.data(), static_cast<std::streamsize>(file.size()));
  if (!in) throw CheckpointError(path + ": cannot read the checkpoint");
  constexpr std::size_t header = sizeof kMagic + sizeof(std::uint32_t) + sizeof(std::uint64_t);
  if (file.size() < header || std::memcmp(file.data(), kMagic, sizeof kMagic) != 0) {
    throw CheckpointError(path + ": not a bondem checkpoint");
  }
  std::uint32_t version = 0;
  std::uint64_t size = 0;
  std::memcpy(&version, file.data() + sizeof kMagic, sizeof version);
  std::memcpy(&size, file.data() + sizeof kMagic + sizeof version, sizeof size);
  if (version != kCheckpointVersion) {
    throw CheckpointError(path + ": checkpoint format version " + std::to_string(version) +
                          ", this bondem reads version " + std::to_string(kCheckpointVersion));
  }
  if (file.size() != header + size + sizeof(std::uint64_t)) {
    throw CheckpointError(path + ": truncated checkpoint (" + std::to_string(file.size()) +
                          " bytes, expected " +
                          std::to_string(header + size + sizeof(std::uint64_t)) + ")");
  }
  const std::string bytes = file.substr(header, size);
  std::uint64_t checksum = 0;
  std::memcpy(&checksum, file.data() + header + size, sizeof checksum);
  if (checksum != fnv1a(bytes.data(), bytes.size())) {
    throw CheckpointError(path + ": checksum mismatch, the checkpoint is corrupt");
  }

  Reader r(bytes, path);
  Checkpoint c;
  StepperState& s = c.stepper;
  c.case_fingerprint = r.get<std::uint64_t>();
  s.time = r.get<double>();
  s.step = r.get<std::int64_t>();
  s.contacts.contacts = r.get<std::uint64_t>();
  s.contacts.bonds = r.get<std::uint64_t>();
  s.contacts.wall_contacts = r.get<std::uint64_t>();
  s.contacts.max_overlap = r.get<double>();
  s.contacts.max_overlap_fraction = r.get<double>();
  s.list.builds = r.get<std::int64_t>();
  const auto n = r.get<std::uint64_t>();
  r.check_room(n, sizeof(double));
  Particles& p = c.particles;
  const auto get_section = [&](CheckpointSection section, std::uint64_t values_per_particle) {
    for (const ParticleField& field : kParticleFields) {
      if (has(field, kCheckpointed) && checkpoint_section(field) == section) {
        std::visit([&](auto member) { r.get(p.*member, n * values_per_particle); }, field.member);
      }
    }
  };
  get_section(CheckpointSection::kParticle, 1);
  for (auto* field : {&s.list.x0, &s.list.y0, &s.list.z0}) r.get(*field, n);
  p.walls = r.get<std::int32_t>();
  if (p.walls < 0) r.fail("negative wall count");
  const auto slip_values_per_particle = 3 * static_cast<std::uint64_t>(p.walls);
  if (slip_values_per_particle > 0 && n > UINT64_MAX / slip_values_per_particle) {
    r.fail("implausible wall count");  // the product below would wrap around
  }
  get_section(CheckpointSection::kWall, slip_values_per_particle);
  const auto slip_count = r.get<std::uint64_t>();
  constexpr std::size_t kSlipBytes = 2 * sizeof(std::int64_t) + 3 * sizeof(double) + 1;
  r.check_room(slip_count, kSlipBytes);
  s.slips.resize(slip_count);
  for (SlipRecord& slip : s.slips) {
    slip.first_id = r.get<std::int64_t>();
    slip.second_id = r.get<std::int64_t>();
    slip.sx = r.get<double>();
    slip.sy = r.get<double>();
    slip.sz = r.get<double>();
    slip.bonded = r.get<std::uint8_t>();
  }
  const auto body_values = r.get<std::uint64_t>();
  r.check_room(body_values, sizeof(double));
  s.bodies.resize(body_values);
  r.get_raw(s.bodies.data(), body_values * sizeof(double));
  s.bonds_formed = r.get<std::int64_t>();
  s.bonds_broken = r.get<std::int64_t>();
  s.laser_energy = r.get<double>();
  s.laser_missed = r.get<double>();
  if (r.get<std::uint8_t>() != 0) get_section(CheckpointSection::kThermal, 1);
  c.history = r.get_text();
  if (!r.at_end()) r.fail("trailing bytes");
  return c;
}

}  // namespace bondem
