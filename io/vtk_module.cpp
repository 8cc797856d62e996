#include "io/vtk_module.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>

namespace bondem {

void* vtk_module_function(const char* name) {
  static std::once_flag once;
  static void* module = nullptr;
  static std::string tried;
  std::call_once(once, [] {
    std::vector<std::string> places;
    if (const char* given = std::getenv("BONDEM_VTK_MODULE"); given != nullptr && *given != '\0') {
      places.emplace_back(given);
    } else {
      std::error_code error;
      const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
      if (!error) places.push_back((self.parent_path() / kVtkModuleName).string());
      places.emplace_back(BONDEM_VTK_MODULE_BUILT);
      places.emplace_back(BONDEM_VTK_MODULE_INSTALLED);
      places.emplace_back(kVtkModuleName);  // dlopen's own search: LD_LIBRARY_PATH, ld.so.cache
    }
    for (const std::string& place : places) {
      // RTLD_LOCAL: VTK's symbols stay the module's; RTLD_NOW: a broken module fails here.
      module = dlopen(place.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (module != nullptr) return;
      tried += "\n  " + place + ": " + dlerror();
    }
  });
  if (module == nullptr) {
    throw std::runtime_error(std::string("cannot load bondem's VTK module ") + kVtkModuleName +
                             " (set BONDEM_VTK_MODULE to its path); tried:" + tried);
  }
  void* function = dlsym(module, name);
  if (function == nullptr) {
    throw std::runtime_error(std::string("bondem's VTK module has no function ") + name);
  }
  return function;
}

}  // namespace bondem
