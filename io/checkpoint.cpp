#include "io/checkpoint.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>

#include "io/atomic_file.hpp"
#include "solver/engine/particles.hpp"

namespace bondem {
namespace {

constexpr char kMagic[8] = {'B', 'O', 'N', 'D', 'E', 'M', 'C', 'K'};
/// Bytes before the payload: magic, version, payload size.
constexpr std::size_t kHeaderBytes = sizeof kMagic + sizeof(std::uint32_t) + sizeof(std::uint64_t);
/// Bytes of a pair's state in the payload, field by field (the struct's padding bytes are not part
/// of the state): its ids, tangential spring and bond flag, and in runs with contact history
/// (Particles::contact_history) its rolling spring and JKR flag too, which are zero in the others:
/// 41 B a pair instead of 66 there (the one-step checkpoint of the 998 400 peer lattice 252 ->
/// 231 MB).
std::size_t slip_bytes(bool contact_history) {
  const std::size_t always =
      2 * sizeof(std::int64_t) + 3 * sizeof(double) + sizeof(SlipRecord::bonded);
  return always + (contact_history ? 3 * sizeof(double) + sizeof(SlipRecord::joined) : 0);
}

/// FNV-1a, 64 bit: simple, dependency-free, and enough to catch truncation and bit rot.
std::uint64_t fnv1a(const char* data, std::size_t size,
                    std::uint64_t hash = 0xcbf29ce484222325ULL) {
  for (std::size_t k = 0; k < size; ++k) {
    hash ^= static_cast<unsigned char>(data[k]);
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

/// The payload's checksum: FNV-1a taken a 64-bit word at a time, then over the last size % 8
/// bytes one at a time. A byte at a time took half a second for the 400 MB of a 10^6 checkpoint.
/// Pieces are hashed in turn, each but the last a multiple of 8 bytes long, so the words are the
/// payload's words however it is cut.
std::uint64_t payload_checksum(const char* data, std::size_t size,
                               std::uint64_t hash = 0xcbf29ce484222325ULL) {
  const std::size_t words = size / 8;
  for (std::size_t w = 0; w < words; ++w) {
    std::uint64_t word = 0;
    std::memcpy(&word, data + 8 * w, sizeof word);
    hash ^= word;
    hash *= 0x100000001b3ULL;
  }
  return fnv1a(data + 8 * words, size - 8 * words, hash);
}

/// Serializes a checkpoint's payload: with a stream, into it through a buffer (hashing the bytes
/// as the buffer fills); without, only counting them. write_checkpoint runs the same serialization
/// twice, counting then writing, so the payload is never held in memory.
class Writer {
 public:
  /// With @p out, writes; without, counts, and runs a distributed checkpoint's streams only when
  /// @p serves (a process other than the writer).
  explicit Writer(std::ostream* out = nullptr, bool serves = false)
      : out_(out), streams_(out != nullptr || serves) {
    if (out_ != nullptr) buffer_.resize(kBufferBytes);
  }
  /// Whether a distributed checkpoint's streams run (not in a counting pass).
  bool streams() const { return streams_; }
  /// Whether the bytes go to a stream (not counted only, nor served).
  bool writes() const { return out_ != nullptr; }
  template <class T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  template <class T, class Allocator>
  void put(const std::vector<T, Allocator>& values) {
    put(static_cast<std::uint64_t>(values.size()));
    append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  }
  /// @p values of @p stride entries per particle, the particles in @p order, as put(values)
  /// writes them stored in that order.
  template <class T, class Allocator>
  void put(const std::vector<T, Allocator>& values, const std::vector<std::uint32_t>& order,
           std::size_t stride) {
    put(static_cast<std::uint64_t>(values.size()));
    if (out_ == nullptr || values.empty()) {
      size_ += values.size() * sizeof(T);
      return;
    }
    for (const std::uint32_t i : order) {
      if (stride == 1) {  // one value: a move of a constant size
        append(reinterpret_cast<const char*>(values.data() + i), sizeof(T));
      } else {
        append(reinterpret_cast<const char*>(values.data() + i * stride), stride * sizeof(T));
      }
    }
  }
  /// @p values (@p stride a particle of this process's part) as put(values, order, stride) of
  /// the whole run's by id writes them, from every process's part through @p parts.
  template <class T, class Allocator>
  void put(const std::vector<T, Allocator>& values, std::size_t stride,
           const DistributedParts& parts) {
    const std::uint64_t count = parts.particles * stride;
    put(count);
    if (!streams_) {
      size_ += count * sizeof(T);
      return;
    }
    parts.column({reinterpret_cast<const char*>(values.data()), stride * sizeof(T)},
                 [this](const char* data, std::size_t size) { append(data, size); });
  }
  /// Counts @p size bytes put elsewhere (a counting pass over what a stream would put).
  void skip(std::uint64_t size) { size_ += size; }
  void put(const std::string& text) {
    put(static_cast<std::uint64_t>(text.size()));
    append(text.data(), text.size());
  }
  /// Bytes put so far.
  std::uint64_t size() const { return size_; }
  /// Writes what the buffer holds and returns payload_checksum() of all bytes put (only with a
  /// stream); the last call.
  std::uint64_t finish() {
    flush();
    return hash_;
  }

 private:
  /// A multiple of 8 (payload_checksum's word).
  static constexpr std::size_t kBufferBytes = std::size_t{1} << 16;

  [[gnu::always_inline]] void append(const char* data, std::size_t size) {
    size_ += size;
    // An empty array's data() may be null, which memcpy must not see even for no bytes.
    if (out_ == nullptr || size == 0) return;
    if (used_ + size < kBufferBytes) {
      // Most puts are one value that fits, the buffer not full after it: one move, of a size
      // known where put() is inlined. A call per value was a fifth of writing a 10^6
      // checkpoint (3 million pairs of 10 values, 1 million particles by id).
      std::memcpy(buffer_.data() + used_, data, size);
      used_ += size;
      return;
    }
    append_filling(data, size);
  }
  /// append() where the bytes fill the buffer: flushes each time it is full.
  [[gnu::noinline]] void append_filling(const char* data, std::size_t size) {
    while (size > 0) {
      const std::size_t room = std::min(size, kBufferBytes - used_);
      std::memcpy(buffer_.data() + used_, data, room);
      used_ += room;
      data += room;
      size -= room;
      if (used_ == kBufferBytes) flush();
    }
  }
  void flush() {
    out_->write(buffer_.data(), static_cast<std::streamsize>(used_));
    hash_ = payload_checksum(buffer_.data(), used_, hash_);
    used_ = 0;
  }

  std::ostream* out_;
  bool streams_;
  std::vector<char> buffer_;
  std::size_t used_ = 0;
  std::uint64_t size_ = 0;
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

/// Reads a checkpoint's payload from a stream, @p size bytes, every read checked against what is
/// left.
class Reader {
 public:
  Reader(std::istream& in, std::uint64_t size, std::string path)
      : in_(in), left_(size), path_(std::move(path)) {}
  template <class T>
  T get() {
    T value;
    take(&value, sizeof(T));
    return value;
  }
  template <class T, class Allocator>
  void get(std::vector<T, Allocator>& values, std::uint64_t expected) {
    const auto size = get<std::uint64_t>();
    if (size != expected)
      fail("array of " + std::to_string(size) + " entries, expected " + std::to_string(expected));
    check_room(size, sizeof(T));
    values.resize(size);
    take(values.data(), size * sizeof(T));
  }
  std::string get_text() {
    const auto size = get<std::uint64_t>();
    if (size > left_) fail("truncated text");
    std::string text(size, '\0');
    take(text.data(), size);
    return text;
  }
  /// As get(values, rows * width), keeping only the rows @p kept (ascending, below @p rows) of
  /// @p width values each, read a block of rows at a time.
  template <class T, class Allocator>
  void get_rows(std::vector<T, Allocator>& values, std::uint64_t rows, std::uint64_t width,
                const std::vector<std::uint64_t>& kept) {
    const auto size = get<std::uint64_t>();
    if (size != rows * width) {
      fail("array of " + std::to_string(size) + " entries, expected " +
           std::to_string(rows * width));
    }
    check_room(size, sizeof(T));
    values.resize(kept.size() * width);
    constexpr std::uint64_t kBlockRows = 4096;
    std::vector<T> block;
    std::size_t at = 0;  // the next kept row
    for (std::uint64_t first = 0; first < rows; first += kBlockRows) {
      const std::uint64_t count = std::min(kBlockRows, rows - first);
      if (at == kept.size() || kept[at] >= first + count) {  // none in this block
        skip(count * width * sizeof(T));
        continue;
      }
      block.resize(count * width);
      take(block.data(), block.size() * sizeof(T));
      for (; at < kept.size() && kept[at] < first + count; ++at) {
        std::copy_n(block.begin() + static_cast<std::ptrdiff_t>((kept[at] - first) * width), width,
                    values.begin() + static_cast<std::ptrdiff_t>(at * width));
      }
    }
  }
  /// Pass over an array of entries of @p entry_size bytes.
  void skip_array(std::size_t entry_size) {
    const auto size = get<std::uint64_t>();
    check_room(size, entry_size);
    skip(size * entry_size);
  }
  /// Pass over @p bytes bytes.
  void skip(std::uint64_t bytes) {
    if (bytes > left_) fail("truncated");
    in_.ignore(static_cast<std::streamsize>(bytes));
    if (!in_) fail("unreadable");
    left_ -= bytes;
  }
  void get_raw(void* out, std::size_t size) { take(out, size); }
  /// Refuse a count of @p count entries of @p entry_size bytes that the bytes left cannot hold:
  /// checked before allocating, so a forged count cannot exhaust memory.
  void check_room(std::uint64_t count, std::size_t entry_size) const {
    if (count > left_ / entry_size) {
      fail("array of " + std::to_string(count) + " entries, more than the file holds");
    }
  }
  bool at_end() const { return left_ == 0; }
  [[noreturn]] void fail(const std::string& what) const {
    throw CheckpointError(path_ + ": corrupt checkpoint: " + what);
  }

 private:
  void take(void* out, std::size_t size) {
    if (size > left_) fail("truncated");
    if (size == 0) return;  // an empty vector's data() may be null, which read must not get
    in_.read(static_cast<char*>(out), static_cast<std::streamsize>(size));
    if (!in_) fail("unreadable");
    left_ -= size;
  }
  std::istream& in_;
  std::uint64_t left_;
  std::string path_;
};

/// Lines `key=value` of the canonical case text, numbers in their shortest exact form: kept as
/// text, or only hashed as they come (a case of a million particles makes a text of 200 MB).
class CanonicalText {
 public:
  explicit CanonicalText(bool keep_text) : keep_text_(keep_text) {}
  void add(const std::string& key, double value) {
    std::array<char, 32> buffer{};
    const std::to_chars_result written =
        std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
    add(key,
        std::string_view(buffer.data(), static_cast<std::size_t>(written.ptr - buffer.data())));
  }
  void add(const std::string& key, int value) { add(key, std::string_view(std::to_string(value))); }
  void add(const std::string& key, bool value) { add(key, std::string_view(value ? "1" : "0")); }
  void add(const std::string& key, std::string_view value) {
    hash_ = fnv1a(key.data(), key.size(), hash_);
    hash_ = fnv1a("=", 1, hash_);
    hash_ = fnv1a(value.data(), value.size(), hash_);
    hash_ = fnv1a("\n", 1, hash_);
    if (keep_text_) text_.append(key).append("=").append(value).append("\n");
  }
  void add(const std::string& key, const Eigen::Vector3d& v) {
    for (int a = 0; a < 3; ++a) add(key + "." + std::to_string(a), v[a]);
  }
  /// Whole lines `key=value\n`, already formatted: the same text and hash as adding them one by
  /// one.
  void add_lines(std::string_view lines) {
    hash_ = fnv1a(lines.data(), lines.size(), hash_);
    if (keep_text_) text_.append(lines);
  }
  /// Whether the text is kept (canonical_case_text) or only hashed (case_fingerprint).
  bool keeps_text() const { return keep_text_; }
  /// Folds the hash of a block of lines hashed elsewhere into the hash (not into the text).
  void add_block_hash(std::uint64_t block) {
    char bytes[sizeof block];
    std::memcpy(bytes, &block, sizeof block);
    hash_ = fnv1a(bytes, sizeof bytes, hash_);
  }
  const std::string& text() const { return text_; }
  /// fnv1a() of the text.
  std::uint64_t hash() const { return hash_; }

 private:
  bool keep_text_;
  std::string text_;
  std::uint64_t hash_ = fnv1a(nullptr, 0);
};

/// Keys of Case::settings that may change on a restart: a run is continued to a later end, and
/// possibly with other output intervals or another output directory.
bool restart_may_change(const std::string& key) {
  return key == "time.end" || key == "output" || key.rfind("output.", 0) == 0;
}

/// Contact model @p m under key @p key.
void write_canonical_contact_model(const std::string& key, const ContactModel& m,
                                   CanonicalText& t) {
  t.add(key + ".damping_ratio", m.damping_ratio);
  t.add(key + ".restitution", m.restitution);
  t.add(key + ".friction", m.friction);
  t.add(key + ".rolling_friction", m.rolling_friction);
  t.add(key + ".rolling_model", static_cast<int>(m.rolling_model));
  t.add(key + ".rolling_damping", m.rolling_damping);
  t.add(key + ".cohesion", static_cast<int>(m.cohesion));
  t.add(key + ".cohesion_energy", m.cohesion_energy);
  const BondModel& bond = m.bond;
  t.add(key + ".bond.alpha", bond.alpha);
  t.add(key + ".bond.input", static_cast<int>(bond.input));
  t.add(key + ".bond.stiffness", bond.stiffness);
  t.add(key + ".bond.equilibrium_overlap", bond.equilibrium_overlap);
  t.add(key + ".bond.damping_ratio", bond.damping_ratio);
  t.add(key + ".bond.criterion", static_cast<int>(bond.criterion));
  t.add(key + ".bond.temperature", bond.temperature);
}

/// Materials, the contact models and laws, the time step and gravity.
void write_canonical_laws(const Case& c, CanonicalText& t) {
  for (std::size_t k = 0; k < c.materials.size(); ++k) {
    const Material& m = c.materials[k];
    const std::string key = "case.materials." + std::to_string(k);
    t.add(key + ".name", std::string_view(m.name));
    t.add(key + ".density", m.density);
    t.add(key + ".youngs_modulus", m.youngs_modulus);
    t.add(key + ".poisson_ratio", m.poisson_ratio);
    t.add(key + ".specific_heat", m.specific_heat);
    t.add(key + ".thermal_conductivity", m.thermal_conductivity);
    t.add(key + ".emissivity", m.emissivity);
  }
  write_canonical_contact_model("case.contact", c.contact, t);
  for (std::size_t k = 0; k < c.interactions.size(); ++k) {
    const Interaction& entry = c.interactions[k];
    const std::string key = "case.interactions." + std::to_string(k);
    t.add(key + ".first_material", entry.first_material);
    t.add(key + ".second_material", entry.second_material);
    write_canonical_contact_model(key, entry.model, t);
  }
  // The law by its place in NormalLawSpec and every parameter it declares.
  t.add("case.normal_law", static_cast<int>(c.normal_law.index()));
  std::visit(
      [&](const auto& law) {
        law.parameters([&](const char* name, const auto& value) {
          t.add("case.normal_law." + std::string(name), value);
        });
      },
      c.normal_law);
  t.add("case.time_step", c.time_step);
  t.add("case.gravity", c.gravity);
}

/// The lines of one particle, formatted as CanonicalText::add() formats them, into a buffer
/// reused from particle to particle: a case of 10^6 particles makes 11 million lines, and a string
/// per key and value took longer than hashing them.
class ParticleLines {
 public:
  /// The lines of particle @p k.
  std::string_view of(std::size_t k, const ParticleSpec& p) {
    end_ = text_.data();
    prefix_end_ = nullptr;
    put("case.particles.");
    end_ = std::to_chars(end_, text_.data() + text_.size(), k).ptr;
    prefix_end_ = end_;
    line(".material", p.material);
    line(".radius", p.radius);
    for (int a = 0; a < 3; ++a) line(kPosition[a], p.position[a]);
    for (int a = 0; a < 3; ++a) line(kVelocity[a], p.velocity[a]);
    line(".temperature", p.temperature);
    for (int a = 0; a < 3; ++a) line(kSpin[a], p.angular_velocity[a]);
    line(".id", p.id);
    return {text_.data(), static_cast<std::size_t>(end_ - text_.data())};
  }

 private:
  static constexpr const char* kPosition[3] = {".position.0", ".position.1", ".position.2"};
  static constexpr const char* kVelocity[3] = {".velocity.0", ".velocity.1", ".velocity.2"};
  static constexpr const char* kSpin[3] = {".angular_velocity.0", ".angular_velocity.1",
                                           ".angular_velocity.2"};
  void put(std::string_view piece) { end_ = std::copy(piece.begin(), piece.end(), end_); }
  /// A line after the first: the key's prefix again, then @p field, '=', @p value and '\n'.
  template <class T>
  void line(std::string_view field, T value) {
    if (end_ != prefix_end_) {
      const std::size_t prefix = static_cast<std::size_t>(prefix_end_ - text_.data());
      end_ = std::copy_n(text_.data(), prefix, end_);
    }
    put(field);
    *end_++ = '=';
    // to_chars of a double without a format: the shortest exact text, as CanonicalText::add.
    end_ = std::to_chars(end_, text_.data() + text_.size(), value).ptr;
    *end_++ = '\n';
  }
  /// 15 lines of at most 15 + 20 + 20 + 1 + 24 + 1 characters.
  std::array<char, 2048> text_{};
  char* end_ = text_.data();
  char* prefix_end_ = nullptr;
};

/// Particles per block of the fingerprint's particle values.
constexpr std::size_t kFingerprintBlock = 4096;

/// Folds the values of @p p that its canonical lines hold (ParticleLines::of) into @p hash, by
/// their bytes, a 64-bit word each.
std::uint64_t hash_particle_values(const ParticleSpec& p, std::uint64_t hash) {
  const double values[11] = {p.radius,
                             p.position.x(),
                             p.position.y(),
                             p.position.z(),
                             p.velocity.x(),
                             p.velocity.y(),
                             p.velocity.z(),
                             p.temperature,
                             p.angular_velocity.x(),
                             p.angular_velocity.y(),
                             p.angular_velocity.z()};
  std::uint64_t words[13];
  words[0] = static_cast<std::uint64_t>(static_cast<std::int64_t>(p.material));
  std::memcpy(words + 1, values, sizeof values);
  words[12] = static_cast<std::uint64_t>(p.id);
  for (const std::uint64_t word : words) {
    hash ^= word;
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

/// Every particle, exactly, and the pair state an initial state brings.
void write_canonical_particles(const Case& c, CanonicalText& t) {
  const std::size_t n = c.particles.size();
  if (t.keeps_text()) {
    ParticleLines lines;
    for (std::size_t k = 0; k < n; ++k) t.add_lines(lines.of(k, c.particles[k]));
  } else {
    // Formatting and hashing 11 lines per particle took a second at 10^6, on one core. The
    // fingerprint hashes the same values by their bytes instead (the text's shortest exact form
    // tells every double apart, and so do its bytes), in blocks on every thread, and folds the
    // block hashes in block order: its value does not depend on the threads.
    const std::size_t blocks = (n + kFingerprintBlock - 1) / kFingerprintBlock;
    std::vector<std::uint64_t> block_hash(blocks);
#pragma omp parallel for schedule(static) num_threads(threads_in_use(n)) if (blocks > 1)
    for (std::size_t b = 0; b < blocks; ++b) {
      std::uint64_t hash = fnv1a(nullptr, 0);
      for (std::size_t k = b * kFingerprintBlock; k < std::min(n, (b + 1) * kFingerprintBlock);
           ++k) {
        hash = hash_particle_values(c.particles[k], hash);
      }
      block_hash[b] = hash;
    }
    for (const std::uint64_t hash : block_hash) t.add_block_hash(hash);
  }
  for (std::size_t k = 0; k < c.initial_pairs.size(); ++k) {
    const SlipRecord& s = c.initial_pairs[k];
    const std::string key = "case.initial_pairs." + std::to_string(k);
    t.add(key + ".ids",
          std::string_view(std::to_string(s.first_id) + " " + std::to_string(s.second_id)));
    t.add(key + ".spring", Eigen::Vector3d(s.sx, s.sy, s.sz));
    t.add(key + ".rolling_spring", Eigen::Vector3d(s.rx, s.ry, s.rz));
    t.add(key + ".flags",
          std::string_view(std::to_string(s.bonded) + " " + std::to_string(s.joined)));
  }
}

/// The domain and the boundaries with their shapes and motions.
void write_canonical_boundaries(const Case& c, CanonicalText& t) {
  if (c.domain) {
    t.add("case.domain.min", c.domain->min);
    t.add("case.domain.max", c.domain->max);
    for (int a = 0; a < 3; ++a) {
      t.add("case.domain.periodic." + std::to_string(a), c.domain->periodic[a]);
    }
  }
  for (std::size_t k = 0; k < c.boundaries.size(); ++k) {
    const Boundary& b = c.boundaries[k];
    const std::string key = "case.boundaries." + std::to_string(k);
    t.add(key + ".name", std::string_view(b.name));
    // The shape by its place in BoundaryShapes and every parameter it declares.
    t.add(key + ".shape", static_cast<int>(b.shape.index()));
    std::visit(
        [&](const auto& shape) {
          shape.parameters(
              [&](const char* name, const auto& value) { t.add(key + ".shape." + name, value); });
        },
        b.shape);
    t.add(key + ".material", b.material);
    t.add(key + ".temperature", b.temperature);
    t.add(key + ".center", b.center);
    t.add(key + ".angle", b.angle);
    t.add(key + ".velocity", b.velocity);
    t.add(key + ".angular_velocity", b.angular_velocity);
    t.add(key + ".motion.interpolation", static_cast<int>(b.motion.interpolation));
    t.add(key + ".motion.axis", b.motion.axis);
    t.add(key + ".motion.spin", b.motion.spin);
    for (std::size_t m = 0; m < b.motion.keys.size(); ++m) {
      const std::string key_m = key + ".motion." + std::to_string(m);
      t.add(key_m + ".time", b.motion.keys[m].time);
      t.add(key_m + ".velocity", b.motion.keys[m].velocity);
      t.add(key_m + ".angular_velocity", b.motion.keys[m].angular_velocity);
    }
  }
}

/// Neighbor settings, the thermal model, the laser and the analysis regions.
void write_canonical_settings(const Case& c, CanonicalText& t) {
  t.add("case.skin", c.skin);
  t.add("case.reorder_interval", c.reorder_interval);
  t.add("case.max_overlap_fraction", c.max_overlap_fraction);
  if (c.thermal) {
    t.add("case.thermal.initial_temperature", c.thermal->initial_temperature);
    t.add("case.thermal.ambient_temperature", c.thermal->ambient_temperature);
    t.add("case.thermal.convection_coefficient", c.thermal->convection_coefficient);
    t.add("case.thermal.radiation", c.thermal->radiation);
  }
  if (c.laser) {
    const Laser& l = *c.laser;
    t.add("case.laser.power", l.power);
    t.add("case.laser.spot_radius", l.spot_radius);
    t.add("case.laser.absorptivity", l.absorptivity);
    t.add("case.laser.start_time", l.start_time);
    for (std::size_t k = 0; k < l.path.size(); ++k) {
      const std::string key = "case.laser.path." + std::to_string(k);
      t.add(key + ".from", Eigen::Vector3d(l.path[k].start.x(), l.path[k].start.y(), 0.0));
      t.add(key + ".to", Eigen::Vector3d(l.path[k].end.x(), l.path[k].end.y(), 0.0));
      t.add(key + ".speed", l.path[k].speed);
    }
  }
  if (c.analysis_region) {
    t.add("case.analysis.region.min", c.analysis_region->min);
    t.add("case.analysis.region.max", c.analysis_region->max);
  }
  if (c.layer) {
    const LayerRegion& r = *c.layer;
    for (const auto& [key, value] :
         {std::pair{"x_min", r.x_min}, std::pair{"x_max", r.x_max}, std::pair{"y_min", r.y_min},
          std::pair{"y_max", r.y_max}, std::pair{"substrate_z", r.substrate_z},
          std::pair{"layer_height", r.layer_height}, std::pair{"grid_spacing", r.grid_spacing}}) {
      t.add(std::string("case.analysis.layer.") + key, value);
    }
    t.add("case.analysis.layer.bins", r.bins);
  }
}

/// Write the canonical text of case @p c into @p t (canonical_case_text() says what it holds):
/// the resolved case, defaults included (what a case built in code has too), then every value
/// the case-file reader read.
void write_canonical(const Case& c, CanonicalText& t) {
  write_canonical_laws(c, t);
  write_canonical_particles(c, t);
  write_canonical_boundaries(c, t);
  write_canonical_settings(c, t);
  // Everything the case-file reader read, whatever the lines above may miss.
  for (const auto& [key, value] : c.settings) {
    if (!restart_may_change(key)) t.add("file." + key, std::string_view(value));
  }
}

}  // namespace

std::string canonical_case_text(const Case& c) {
  CanonicalText t(true);
  write_canonical(c, t);
  return t.text();
}

std::uint64_t case_fingerprint(const Case& c) {
  CanonicalText t(false);
  write_canonical(c, t);
  return t.hash();
}

namespace {

/// The checkpoint's payload, into @p payload; @p slips is the number of pairs
/// checkpoint.for_each_slip visits.
void put_payload(Writer& payload, const CheckpointView& checkpoint, std::uint64_t slips) {
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
  const std::optional<DistributedParts>& parts = checkpoint.parts;
  payload.put(static_cast<std::uint64_t>(parts ? parts->particles : p.size()));
  const std::vector<std::uint32_t>& by_id = *checkpoint.by_id;
  // A column of values by id: this process's, or every process's part's.
  const auto put_column = [&](const auto& values, std::size_t stride) {
    if (parts) {
      payload.put(values, stride, *parts);
    } else {
      payload.put(values, by_id, stride);
    }
  };
  const auto put_section = [&](CheckpointSection section) {
    for (const ParticleField& field : kParticleFields) {
      if (has(field, kCheckpointed) && checkpoint_section(field) == section) {
        std::visit([&](auto member) { put_column(p.*member, values_per_particle(field, p)); },
                   field.member);
      }
    }
  };
  put_section(CheckpointSection::kParticle);
  for (const StaggeredVector<double>* axis : checkpoint.build_positions) put_column(*axis, 1);
  payload.put(static_cast<std::int32_t>(p.walls));
  put_section(CheckpointSection::kWall);
  // Whether the run has contact history, ahead of the pairs, whose records carry it only then,
  // and of its particle fields below. Field by field: the struct's padding bytes are not part of
  // the state.
  const bool history = p.contact_history;
  payload.put(static_cast<std::uint8_t>(history ? 1 : 0));
  payload.put(slips);
  std::uint64_t visited = 0;
  if (!payload.streams()) {
    // counted: the pairs are walked in the writing pass
    payload.skip(slips * slip_bytes(history));
  } else {
    checkpoint.for_each_slip([&](const SlipRecord& slip) {
      payload.put(slip.first_id);
      payload.put(slip.second_id);
      for (const double v : {slip.sx, slip.sy, slip.sz}) payload.put(v);
      payload.put(slip.bonded);
      if (history) {
        for (const double v : {slip.rx, slip.ry, slip.rz}) payload.put(v);
        payload.put(slip.joined);
      }
      ++visited;
    });
    // A serving process visits none: the writer checks the count.
    if (payload.writes() && visited != slips) {
      throw std::logic_error("checkpoint: the pairs' state changed its count");
    }
  }
  payload.put(s.boundaries);
  payload.put(s.bonds_formed);
  payload.put(s.bonds_broken);
  payload.put(s.laser_energy);
  payload.put(s.laser_missed);
  payload.put(s.next_particle_id);
  payload.put(static_cast<std::uint64_t>(s.streams.size()));
  for (const ParticleTally& stream : s.streams) {
    payload.put(stream.count);
    payload.put(stream.mass);
  }
  payload.put(s.removed.count);
  payload.put(s.removed.mass);
  // Thermal arrays, one value per particle, only in thermal runs.
  payload.put(static_cast<std::uint8_t>(p.thermal() ? 1 : 0));
  if (p.thermal()) put_section(CheckpointSection::kThermal);
  if (history) put_section(CheckpointSection::kContactHistory);
  payload.put(static_cast<std::uint8_t>(p.displacement_tracked ? 1 : 0));
  if (p.displacement_tracked) put_section(CheckpointSection::kDisplacement);
  payload.put(static_cast<std::uint8_t>(p.mesh_contacts ? 1 : 0));
  if (p.mesh_contacts) put_section(CheckpointSection::kMeshHistory);
  payload.put(checkpoint.history);
  payload.put(static_cast<std::uint64_t>(checkpoint.material_names.size()));
  for (const std::string& name : checkpoint.material_names) payload.put(name);
}

}  // namespace

CheckpointView checkpoint_view(const Checkpoint& checkpoint) {
  const StepperState& s = checkpoint.stepper;
  return {checkpoint.case_fingerprint,
          checkpoint.particles,
          s,
          checkpoint.history,
          checkpoint.material_names,
          {&s.list.x0, &s.list.y0, &s.list.z0},
          [&s](const std::function<void(const SlipRecord&)>& visit) {
            for (const SlipRecord& slip : s.slips) visit(slip);  // by ids (collect_slips)
          },
          std::make_shared<const std::vector<std::uint32_t>>(checkpoint.particles.order_by_id()),
          std::nullopt,
          s.slips.size()};
}

CheckpointView checkpoint_view(std::uint64_t case_fingerprint, const Particles& particles,
                               const Stepper& stepper, const StepperState& state,
                               const std::string& history,
                               const std::vector<std::string>& material_names) {
  const NeighborList& list = stepper.neighbors();
  auto by_id = std::make_shared<const std::vector<std::uint32_t>>(particles.order_by_id());
  return {case_fingerprint,
          particles,
          state,
          history,
          material_names,
          {&list.build_positions(0), &list.build_positions(1), &list.build_positions(2)},
          [&stepper, by_id](const std::function<void(const SlipRecord&)>& visit) {
            stepper.for_each_slip(*by_id, visit);
          },
          by_id,
          std::nullopt,
          stepper.slip_count()};
}

void write_checkpoint(const std::string& path, const CheckpointView& checkpoint) {
  std::uint64_t slips = checkpoint.parts   ? checkpoint.parts->slips
                        : checkpoint.slips ? *checkpoint.slips
                                           : 0;
  if (!checkpoint.parts && !checkpoint.slips)
    checkpoint.for_each_slip([&slips](const SlipRecord& /*slip*/) { ++slips; });
  Writer counter;
  put_payload(counter, checkpoint, slips);
  std::optional<AtomicFile> opened;
  try {
    opened.emplace(path);
  } catch (...) {
    // The other processes are in the streams: they are served before the error travels on.
    if (checkpoint.parts) serve_checkpoint(checkpoint);
    throw;
  }
  AtomicFile& file = *opened;
  std::ostream& out = file.stream();
  out.write(kMagic, sizeof kMagic);
  const std::uint32_t version = kCheckpointVersion;
  const std::uint64_t size = counter.size();
  out.write(reinterpret_cast<const char*>(&version), sizeof version);
  out.write(reinterpret_cast<const char*>(&size), sizeof size);
  Writer payload(&out);
  put_payload(payload, checkpoint, slips);
  if (payload.size() != size) throw std::logic_error("checkpoint: the payload changed its size");
  const std::uint64_t checksum = payload.finish();
  out.write(reinterpret_cast<const char*>(&checksum), sizeof checksum);
  file.commit();
}

void serve_checkpoint(const CheckpointView& checkpoint) {
  if (!checkpoint.parts) throw std::logic_error("serve_checkpoint: not a distributed checkpoint");
  Writer server(nullptr, true);
  put_payload(server, checkpoint, checkpoint.parts->slips);
}

void write_checkpoint(const std::string& path, const Checkpoint& checkpoint) {
  write_checkpoint(path, checkpoint_view(checkpoint));
}

namespace {

/// The checkpoint file at @p path, opened at its payload of @p size bytes, after checking that it
/// is a regular file, its magic, its version, its size against the header and its checksum. The
/// payload is hashed in pieces as it is read, then read again by the caller: the file (hundreds
/// of megabytes at 10^6 particles) is never held in memory beside the state read from it.
std::ifstream open_checked_payload(const std::string& path, std::uint64_t& size,
                                   bool verify = true) {
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
  const std::streamoff signed_length = in.tellg();
  if (signed_length < 0) throw CheckpointError(path + ": cannot read the checkpoint");
  const auto length = static_cast<std::uint64_t>(signed_length);
  std::array<char, kHeaderBytes> header{};
  in.seekg(0);
  if (length >= kHeaderBytes) in.read(header.data(), header.size());
  if (!in) throw CheckpointError(path + ": cannot read the checkpoint");
  if (length < kHeaderBytes || std::memcmp(header.data(), kMagic, sizeof kMagic) != 0) {
    throw CheckpointError(path + ": not a bondem checkpoint");
  }
  std::uint32_t version = 0;
  std::memcpy(&version, header.data() + sizeof kMagic, sizeof version);
  std::memcpy(&size, header.data() + sizeof kMagic + sizeof version, sizeof size);
  if (version != kCheckpointVersion) {
    throw CheckpointError(path + ": checkpoint format version " + std::to_string(version) +
                          ", this bondem reads version " + std::to_string(kCheckpointVersion));
  }
  // In this order: a forged size near 2^64 must not wrap the sum.
  if (length - kHeaderBytes < sizeof(std::uint64_t) ||
      size != length - kHeaderBytes - sizeof(std::uint64_t)) {
    throw CheckpointError(path + ": truncated checkpoint (" + std::to_string(length) +
                          " bytes, expected " +
                          std::to_string(kHeaderBytes + size + sizeof(std::uint64_t)) + ")");
  }
  if (!verify) {
    in.seekg(static_cast<std::streamoff>(kHeaderBytes));
    return in;
  }
  std::vector<char> piece(std::size_t{1} << 20U);
  std::uint64_t hash = fnv1a(nullptr, 0);
  for (std::uint64_t left = size; left > 0;) {
    const auto count = static_cast<std::size_t>(std::min<std::uint64_t>(left, piece.size()));
    in.read(piece.data(), static_cast<std::streamsize>(count));
    if (!in) throw CheckpointError(path + ": cannot read the checkpoint");
    hash = payload_checksum(piece.data(), count, hash);  // 1 MiB pieces: whole words
    left -= count;
  }
  std::uint64_t checksum = 0;
  in.read(reinterpret_cast<char*>(&checksum), sizeof checksum);
  if (!in) throw CheckpointError(path + ": cannot read the checkpoint");
  if (checksum != hash) {
    throw CheckpointError(path + ": checksum mismatch, the checkpoint is corrupt");
  }
  in.seekg(static_cast<std::streamoff>(kHeaderBytes));
  return in;
}

/// One pair's record, as write_checkpoint() writes it (@p history: with its rolling spring and
/// JKR flag, slip_bytes).
SlipRecord read_slip(Reader& r, bool history) {
  SlipRecord slip{};
  slip.first_id = r.get<std::int64_t>();
  slip.second_id = r.get<std::int64_t>();
  slip.sx = r.get<double>();
  slip.sy = r.get<double>();
  slip.sz = r.get<double>();
  slip.bonded = r.get<std::uint8_t>();
  if (history) {
    slip.rx = r.get<double>();
    slip.ry = r.get<double>();
    slip.rz = r.get<double>();
    slip.joined = r.get<std::uint8_t>();
  }
  return slip;
}

/// Visits the @p count pair records (@p history as in read_slip) at byte @p at of checkpoint
/// @p path, read from @p in (kept open: a checkpoint is replaced by a rename, which leaves the
/// verified file this reads).
SlipSource streamed_slips(std::shared_ptr<std::ifstream> in, std::streamoff at, std::uint64_t count,
                          bool history, std::string path) {
  return [in = std::move(in), at, count, history,
          path = std::move(path)](const std::function<void(const SlipRecord&)>& visit) {
    in->clear();
    in->seekg(at);
    Reader r(*in, count * slip_bytes(history), path);
    for (std::uint64_t k = 0; k < count; ++k) visit(read_slip(r, history));
  };
}

}  // namespace

Checkpoint read_checkpoint(const std::string& path, const CheckpointScope& scope) {
  std::uint64_t size = 0;
  auto in = std::make_shared<std::ifstream>(open_checked_payload(path, size, !scope.head_only));
  Reader r(*in, size, path);
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
  c.file_particles = n;
  if (scope.head_only) return c;
  if (scope.rows != nullptr) {
    const std::vector<std::uint64_t>& rows = *scope.rows;
    for (std::size_t k = 0; k < rows.size(); ++k) {
      if (rows[k] >= n || (k > 0 && rows[k] <= rows[k - 1])) {
        r.fail("holds " + std::to_string(n) + " particles: row " + std::to_string(rows[k]) +
               " asked for is not in it, or not in order");
      }
    }
  }
  Particles& p = c.particles;
  // Per-wall fields hold wall_values per wall: the wall count is read before their section.
  const auto get_section = [&](CheckpointSection section) {
    for (const ParticleField& field : kParticleFields) {
      if (has(field, kCheckpointed) && checkpoint_section(field) == section) {
        const std::uint64_t width = values_per_particle(field, p);
        if (width > 1 && n > UINT64_MAX / width) r.fail("implausible wall count");
        std::visit(
            [&](auto member) {
              auto& values = p.*member;
              using Value = typename std::decay_t<decltype(values)>::value_type;
              const std::string_view name = field.name;
              if (scope.positions_only && name != "id" && name != "x" && name != "y" &&
                  name != "z" && name != "radius") {
                r.skip_array(sizeof(Value));
              } else if (scope.rows != nullptr) {
                r.get_rows(values, n, width, *scope.rows);
              } else {
                r.get(values, n * width);
              }
            },
            field.member);
      }
    }
  };
  get_section(CheckpointSection::kParticle);
  if (scope.positions_only) return c;  // the checksum was verified over the whole payload
  for (auto* field : {&s.list.x0, &s.list.y0, &s.list.z0}) {
    if (scope.rows != nullptr) {
      r.get_rows(*field, n, 1, *scope.rows);
    } else {
      r.get(*field, n);
    }
  }
  p.walls = r.get<std::int32_t>();
  if (p.walls < 0) r.fail("negative wall count");
  if (p.walls > INT32_MAX / Particles::kWallContactValues) r.fail("implausible wall count");
  get_section(CheckpointSection::kWall);
  const std::uint8_t history = r.get<std::uint8_t>();
  if (history > 1) r.fail("invalid contact history flag");
  p.contact_history = history != 0;
  const auto slip_count = r.get<std::uint64_t>();
  const std::size_t slip_size = slip_bytes(p.contact_history);
  r.check_room(slip_count, slip_size);
  // With rows kept, the pairs of a kept particle (the kept ids are in order: the file is by id).
  const auto kept = [&](std::int64_t id) {
    return std::binary_search(p.id.begin(), p.id.end(), id);
  };
  if (scope.pairs_streamed) {
    s.slip_source = streamed_slips(in, in->tellg(), slip_count, p.contact_history, path);
    r.skip(slip_count * slip_size);
  } else {
    if (scope.rows == nullptr) s.slips.reserve(slip_count);
    for (std::uint64_t k = 0; k < slip_count; ++k) {
      const SlipRecord slip = read_slip(r, p.contact_history);
      if (scope.rows == nullptr || kept(slip.first_id) || kept(slip.second_id)) {
        s.slips.push_back(slip);
      }
    }
  }
  const auto boundary_values = r.get<std::uint64_t>();
  r.check_room(boundary_values, sizeof(double));
  s.boundaries.resize(boundary_values);
  r.get_raw(s.boundaries.data(), boundary_values * sizeof(double));
  s.bonds_formed = r.get<std::int64_t>();
  s.bonds_broken = r.get<std::int64_t>();
  s.laser_energy = r.get<double>();
  s.laser_missed = r.get<double>();
  s.next_particle_id = r.get<std::int64_t>();
  const auto streams = r.get<std::uint64_t>();
  r.check_room(streams, sizeof(std::int64_t) + sizeof(double));
  s.streams.resize(streams);
  for (ParticleTally& stream : s.streams) {
    stream.count = r.get<std::int64_t>();
    stream.mass = r.get<double>();
  }
  s.removed.count = r.get<std::int64_t>();
  s.removed.mass = r.get<double>();
  p.temperatures_tracked = r.get<std::uint8_t>() != 0;
  if (p.temperatures_tracked) get_section(CheckpointSection::kThermal);
  if (p.contact_history) get_section(CheckpointSection::kContactHistory);
  p.displacement_tracked = r.get<std::uint8_t>() != 0;
  if (p.displacement_tracked) get_section(CheckpointSection::kDisplacement);
  p.mesh_contacts = r.get<std::uint8_t>() != 0;
  if (p.mesh_contacts) get_section(CheckpointSection::kMeshHistory);
  c.history = r.get_text();
  const auto names = r.get<std::uint64_t>();
  r.check_room(names, sizeof(std::uint64_t));
  for (std::uint64_t k = 0; k < names; ++k) c.material_names.push_back(r.get_text());
  if (!r.at_end()) r.fail("trailing bytes");
  // A field the table does not checkpoint restarts from zero, sized like the others, so that it
  // is never an empty array the stepper writes past.
  for (const ParticleField& field : kParticleFields) {
    if (has(field, kCheckpointed) || !in_use(field, p)) continue;
    const std::size_t width = values_per_particle(field, p);
    std::visit([&](auto member) { (p.*member).assign(p.size() * width, {}); }, field.member);
  }
  return c;
}

Checkpoint read_checkpoint(const std::string& path) {
  return read_checkpoint(path, CheckpointScope{});
}

Checkpoint read_checkpoint(const std::string& path, const std::vector<std::uint64_t>& rows) {
  return read_checkpoint(path, CheckpointScope{&rows});
}

Particles read_checkpoint_positions(const std::string& path) {
  return std::move(read_checkpoint(path, CheckpointScope{nullptr, true}).particles);
}

}  // namespace bondem
