// The table of particle fields (kParticleFields) and what reads it: add, permute, the last-good
// state and the checkpoint writer and reader. Every test walks the table, so a field added to it is
// covered without touching these tests.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <iterator>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/checkpoint.hpp"
#include "io/run_observers.hpp"
#include "run_helpers.hpp"
#include "solver/driver/history.hpp"
#include "solver/engine/particles.hpp"
#include "solver/engine/scene.hpp"

namespace bondem {
namespace {

constexpr std::size_t kCount = 7;
constexpr int kWalls = 2;

/// Value k of row @p row: distinct across rows and entries, exact in every element type.
double value_of(std::size_t row, std::size_t k) {
  return static_cast<double>(1000 * (row + 1) + k);
}

/// @p count particles with walls, temperatures and contact history, every field of the table
/// filled with value_of(row, k).
Particles filled(std::size_t count = kCount) {
  Particles p;
  p.walls = kWalls;
  p.contact_history = true;
  p.displacement_tracked = true;
  p.mesh_contacts = true;
  p.temperatures_tracked = true;
  std::size_t row = 0;
  for (const ParticleField& field : kParticleFields) {
    const std::size_t per = values_per_particle(field, p);
    std::visit(
        [&](auto member) {
          auto& values = p.*member;
          values.resize(count * per);
          for (std::size_t k = 0; k < values.size(); ++k) {
            values[k] =
                static_cast<typename std::decay_t<decltype(values)>::value_type>(value_of(row, k));
          }
        },
        field.member);
    ++row;
  }
  return p;
}

/// The values of @p field in @p p, as doubles.
std::vector<double> values(const Particles& p, const ParticleField& field) {
  return std::visit(
      [&](auto member) {
        const auto& v = p.*member;
        return std::vector<double>(v.begin(), v.end());
      },
      field.member);
}

TEST(ParticleFields, AddGrowsEveryFieldInUse) {
  for (const bool thermal : {false, true}) {
    Particles p;
    p.contact_history = thermal;  // every kind of optional field, on and off
    p.displacement_tracked = thermal;
    p.mesh_contacts = thermal;
    p.set_wall_count(kWalls);
    const double position[3] = {1.0, 2.0, 3.0};
    const double velocity[3] = {4.0, 5.0, 6.0};
    p.add(9, 1, 0.5, 2.0, position, velocity);
    if (thermal) {
      p.track_temperatures();
      for (const ParticleField& field : kParticleFields) {
        EXPECT_EQ(values(p, field).size(), values_per_particle(field, p)) << field.name;
      }
      p.temperature[0] = 300.0;
    }
    p.add(10, 0, 0.25, 1.0, position, velocity);
    ASSERT_EQ(p.size(), 2u);
    EXPECT_EQ(p.thermal(), thermal);
    for (const ParticleField& field : kParticleFields) {
      const std::size_t expected =
          in_use(field, p) ? 2 * values_per_particle(field, p) : std::size_t{0};
      EXPECT_EQ(values(p, field).size(), expected) << field.name << (thermal ? " thermal" : "");
    }
    EXPECT_EQ(p.id[1], 10);
    EXPECT_EQ(p.material[1], 0);
    EXPECT_EQ(p.radius[1], 0.25);
    EXPECT_EQ(p.mass[1], 1.0);
    EXPECT_EQ(p.z[1], 3.0);
    EXPECT_EQ(p.vx[1], 4.0);
    EXPECT_EQ(p.fx[1], 0.0);
    EXPECT_EQ(p.wall_slip.back(), 0.0);
    EXPECT_EQ(p.wall_contact.size(), thermal ? 2 * 4 * kWalls : 0u);
    if (thermal) {
      EXPECT_EQ(p.temperature[0], 300.0);
      EXPECT_EQ(p.temperature[1], 0.0);
    }
  }
}

TEST(ParticleFields, PermuteMovesEveryReorderedFieldWithItsParticle) {
  const Particles before = filled();
  Particles after = before;
  const std::vector<std::uint32_t> order = {3, 0, 6, 1, 5, 2, 4};
  after.permute(order);
  for (const ParticleField& field : kParticleFields) {
    ASSERT_TRUE(has(field, kReordered)) << field.name << ": every field today moves";
    const std::size_t per = values_per_particle(field, before);
    const std::vector<double> old_values = values(before, field);
    const std::vector<double> new_values = values(after, field);
    ASSERT_EQ(new_values.size(), kCount * per) << field.name;
    for (std::size_t k = 0; k < kCount; ++k) {
      for (std::size_t c = 0; c < per; ++c) {
        EXPECT_EQ(new_values[k * per + c], old_values[order[k] * per + c]) << field.name;
      }
    }
  }
}

TEST(ParticleFields, PermuteOfManyOnEveryThreadMovesEachValueAndKeepsNoSpareCapacity) {
  // 5 000 particles: the gather runs on every thread, and in place each double array's old
  // buffer is handed to the next one; per-wall arrays (kWalls x 3 or 4 values a particle) sit
  // beside one-value arrays. Every value must follow its particle, and no array may keep a
  // buffer much larger than it needs (the 10^6 memory target counts every byte).
  constexpr std::size_t kMany = 5000;
  const Particles before = filled(kMany);
  Particles after = before;
  std::vector<std::uint32_t> order(kMany);
  for (std::size_t k = 0; k < kMany; ++k) order[k] = static_cast<std::uint32_t>((k * 7919) % kMany);
  after.permute(order);
  for (const ParticleField& field : kParticleFields) {
    const std::size_t per = values_per_particle(field, before);
    const std::vector<double> old_values = values(before, field);
    const std::vector<double> new_values = values(after, field);
    ASSERT_EQ(new_values.size(), kMany * per) << field.name;
    std::size_t moved_wrong = 0;
    for (std::size_t k = 0; k < kMany; ++k) {
      for (std::size_t c = 0; c < per; ++c) {
        moved_wrong += new_values[k * per + c] != old_values[order[k] * per + c] ? 1 : 0;
      }
    }
    EXPECT_EQ(moved_wrong, 0u) << field.name;
    std::visit(
        [&](auto member) {
          const auto& array = after.*member;
          EXPECT_LE(array.capacity(), array.size() + array.size() / 8) << field.name;
        },
        field.member);
  }
}

TEST(ParticleFields, LastGoodMarksExactlyWhatAFinalStateHolds) {
  // LastGoodFile keeps the kLastGood fields and writes them as a final-state file: ids,
  // materials, positions, velocities, radii and spins, and nothing else (92 B a particle on
  // disk), so that a run can start from it (initial_state).
  std::vector<std::string_view> marked;
  for (const ParticleField& field : kParticleFields) {
    if (has(field, kLastGood)) marked.push_back(field.name);
  }
  EXPECT_EQ(marked, (std::vector<std::string_view>{"id", "material", "x", "y", "z", "vx", "vy",
                                                   "vz", "radius", "wx", "wy", "wz"}));
}

// The last-good state goes to its scratch file through a FileWriteBuffer, past the page cache
// once it outgrows one buffer. Kept twice and read back each time, a state of several buffers
// must come back exactly: its reads go through the same open file, which the writes must not
// leave in direct mode (unaligned reads would then fail).
TEST(ParticleFields, LastGoodStateOfSeveralWriteBuffersReadsBackExactly) {
  const std::filesystem::path directory = testing::fresh_directory("particle_fields_last_good");
  std::filesystem::create_directories(directory);
  // 92 B a particle on disk: a little more than two buffers and a half.
  const std::size_t count = 5 * FileWriteBuffer::kBufferBytes / 2 / 92 + 7;
  const Scene scene;
  const History history(scene, 1);
  Particles state = filled(count);
  LastGoodFile last_good((directory / "last_good_state.csv").string(), state, history);
  for (const int round : {0, 1}) {
    if (round == 1) {  // a later history row: other values over the same file
      for (double& x : state.x) x += 0.5;
      last_good.keep(state);
    }
    const Particles kept = last_good.kept();
    for (const ParticleField& field : kParticleFields) {
      if (!has(field, kLastGood)) continue;
      EXPECT_TRUE(values(kept, field) == values(state, field))
          << field.name << " after keep " << round;
    }
  }
}

TEST(ParticleFields, FinalStateOfManyBlocksIsInIdOrderAndTheSameOnAnyThreadCount) {
  // Blocks of 2 048 rows are formatted on every thread and written in turn: with a dozen blocks
  // and ids that run against the storage order, a block written out of its turn shows as a
  // row out of id order or as bytes that differ between one and two threads.
  const std::filesystem::path directory = testing::fresh_directory("particle_fields_final_state");
  constexpr std::size_t kRows = 12 * 2048 + 5;
  Particles p;
  for (std::size_t i = 0; i < kRows; ++i) {
    const double position[3] = {1.0 / 3.0 + static_cast<double>(i), 0.1, -0.2};
    const double velocity[3] = {0.0, 0.5, 0.25 * static_cast<double>(i)};
    p.add(static_cast<std::int64_t>(kRows - 1 - i), 0, 1e-3, 2e-6, position, velocity);
  }
  const std::vector<std::string> names = {"glass"};
  const int threads = omp_get_max_threads();
  std::vector<std::string> texts;
  for (const int team : {1, 2}) {
    omp_set_num_threads(team);
    const std::filesystem::path path = directory / ("final_" + std::to_string(team) + ".csv");
    write_final_state(p, names, path.string());
    texts.push_back(testing::file_bytes(path));
  }
  omp_set_num_threads(threads);
  EXPECT_TRUE(texts[0] == texts[1]) << "final_state.csv differs between one and two threads";
  std::istringstream in(texts[1]);
  std::string line;
  std::getline(in, line);  // the header
  std::size_t rows = 0;
  while (std::getline(in, line)) {
    const std::int64_t id = std::stoll(line.substr(0, line.find(',')));
    const std::size_t i = kRows - 1 - static_cast<std::size_t>(id);
    ASSERT_EQ(id, static_cast<std::int64_t>(rows)) << "row " << rows << " out of id order";
    ASSERT_EQ(std::stod(line.substr(line.find(',') + 1)), p.x[i]) << "row " << rows;
    ++rows;
  }
  EXPECT_EQ(rows, kRows);
}

TEST(ParticleFields, CheckpointKeepsEveryCheckpointedFieldExactly) {
  const std::filesystem::path directory = testing::fresh_directory("particle_fields_checkpoint");
  for (const bool thermal : {true, false}) {
    Checkpoint written;
    written.particles = filled();
    // Without temperatures, also without contact history: each optional section both ways.
    written.particles.contact_history = thermal;
    written.particles.displacement_tracked = thermal;
    written.particles.mesh_contacts = thermal;
    written.particles.temperatures_tracked = thermal;
    if (!thermal) {
      for (const ParticleField& field : kParticleFields) {
        if (!in_use(field, written.particles) || has(field, kThermal)) {
          std::visit([&](auto member) { (written.particles.*member).clear(); }, field.member);
        }
      }
    }
    for (auto* field :
         {&written.stepper.list.x0, &written.stepper.list.y0, &written.stepper.list.z0}) {
      field->assign(kCount, 0.5);
    }
    const std::string path = (directory / "fields.bin").string();
    write_checkpoint(path, written);
    const Checkpoint read = read_checkpoint(path);
    EXPECT_EQ(read.particles.walls, kWalls);
    for (const ParticleField& field : kParticleFields) {
      std::vector<double> expected = values(written.particles, field);
      // A field not checkpointed comes back as zeros, one per value it had (never empty).
      if (!has(field, kCheckpointed)) std::fill(expected.begin(), expected.end(), 0.0);
      EXPECT_EQ(values(read.particles, field), expected)
          << field.name << (thermal ? " thermal" : "");
    }
  }
}

// The displacement moves with its particle and is checkpointed (a restart continues it), is not
// part of the last-good state (a final-state file has no column for it), and is one VTK vector.
TEST(ParticleFields, DisplacementIsReorderedCheckpointedAndAVtkVector) {
  int component = 0;
  for (const char* name : {"dx", "dy", "dz"}) {
    const ParticleField* field =
        std::find_if(std::begin(kParticleFields), std::end(kParticleFields),
                     [&](const ParticleField& f) { return f.name == name; });
    ASSERT_NE(field, std::end(kParticleFields)) << name;
    EXPECT_TRUE(has(*field, kReordered | kCheckpointed)) << name;
    EXPECT_FALSE(has(*field, kLastGood) || has(*field, kThermal) || has(*field, kPerWall)) << name;
    EXPECT_EQ(field->vtk_name, "displacement") << name;
    EXPECT_EQ(field->vtk_component, component++) << name;
  }
}

TEST(ParticleOrder, ByIdForConsecutiveSparseAndRepeatedIds) {
  // order_by_id places consecutive ids directly and sorts any other set: both must give the
  // indices in increasing id, whatever the storage order.
  const auto order_of = [](const std::vector<std::int64_t>& ids) {
    Particles p;
    p.id.assign(ids.begin(), ids.end());
    return p.order_by_id();
  };
  const auto sorted_by_id = [](const std::vector<std::int64_t>& ids) {
    std::vector<std::uint32_t> order(ids.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<std::uint32_t>(i);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return ids[a] < ids[b]; });
    return order;
  };
  const std::vector<std::vector<std::int64_t>> cases = {
      {},
      {42},
      {12, 10, 14, 11, 13},  // consecutive, shuffled
      {5, 6, 7, 8},          // consecutive, in order
      {30, 10, 20, 0},       // sparse
      {3, 1, 3, 2},          // min..max spans the count but an id repeats
      {-2, 1, -1, 0},        // consecutive through zero
  };
  for (const std::vector<std::int64_t>& ids : cases) {
    const std::vector<std::uint32_t> order = order_of(ids);
    ASSERT_EQ(order.size(), ids.size());
    if (std::set<std::int64_t>(ids.begin(), ids.end()).size() == ids.size()) {
      EXPECT_EQ(order, sorted_by_id(ids));
    } else {
      // A repeated id: any order that sorts the ids will do.
      EXPECT_TRUE(std::is_sorted(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        return ids[a] < ids[b];
      }));
      EXPECT_EQ(std::set<std::uint32_t>(order.begin(), order.end()).size(), ids.size());
    }
  }
}

}  // namespace
}  // namespace bondem
