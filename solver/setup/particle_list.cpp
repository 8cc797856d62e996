#include "solver/setup/particle_list.hpp"

#include <algorithm>
#include <utility>

namespace bondem {

ParticleList::ParticleList(std::vector<ParticleSpec> specs) {
  append(std::move(specs));
}

ParticleList::ParticleList(std::initializer_list<ParticleSpec> specs)
    : ParticleList(std::vector<ParticleSpec>(specs)) {}

const ParticleList::Segment& ParticleList::segment_of(std::size_t i) const {
  if (segments_.size() == 1) return segments_.front();
  const auto after =
      std::upper_bound(segments_.begin(), segments_.end(), i,
                       [](std::size_t index, const Segment& s) { return index < s.first; });
  return *(after - 1);
}

const ParticleSpec ParticleList::operator[](std::size_t i) const {
  const Segment& s = segment_of(i);
  return s.is_lattice ? s.lattice.at(i - s.first) : stored_[s.stored_first + (i - s.first)];
}

void ParticleList::push_back(const ParticleSpec& spec) {
  if (segments_.empty() || segments_.back().is_lattice) {
    Segment run;
    run.first = size();
    run.stored_first = stored_.size();
    segments_.push_back(run);
  }
  stored_.push_back(spec);
}

void ParticleList::append(std::vector<ParticleSpec> specs) {
  if (specs.empty()) return;
  if (segments_.empty() || segments_.back().is_lattice) {
    Segment run;
    run.first = size();
    run.stored_first = stored_.size();
    segments_.push_back(run);
  }
  // Moved when nothing is stored yet: copying 10^6 specs with the regrowth took a tenth of the
  // set-up of a 10^6 lattice.
  if (stored_.empty()) {
    stored_ = std::move(specs);
  } else {
    stored_.insert(stored_.end(), specs.begin(), specs.end());
  }
}

void ParticleList::append(const LatticeBlock& block) {
  if (block.size() == 0) return;
  segments_.push_back({.first = size(), .is_lattice = true, .lattice = block});
  in_blocks_ += block.size();
}

std::vector<ParticleSpec>& ParticleList::expanded() {
  if (in_blocks_ == 0) {
    // One stored run from the start, also for a list that the caller fills through the vector.
    if (segments_.empty()) segments_.assign(1, Segment{});
    return stored_;
  }
  std::vector<ParticleSpec> all;
  all.reserve(size());
  for (std::size_t i = 0; i < size(); ++i) all.push_back((*this)[i]);
  stored_ = std::move(all);
  segments_.assign(1, Segment{});
  in_blocks_ = 0;
  return stored_;
}

ParticleSpec& ParticleList::edit(std::size_t i) {
  return expanded()[i];
}

std::vector<LatticeBlock> ParticleList::lattice_blocks() const {
  std::vector<LatticeBlock> blocks;
  for (const Segment& s : segments_) {
    if (s.is_lattice) blocks.push_back(s.lattice);
  }
  return blocks;
}

void ParticleList::clear() {
  std::vector<ParticleSpec>().swap(stored_);
  segments_.clear();
  in_blocks_ = 0;
}

}  // namespace bondem
