// `ffseg`: segment organs in NIfTI volumes from the command line.
#include <cstdio>
#include <cstring>
#include <exception>
#include <new>
#include <string>

#include "cli.h"
#include "ffseg.h"

namespace {

const char* const kMainUsage =
    "usage: ffseg COMMAND [OPTIONS]\n"
    "\n"
    "Segment organs in 3D medical volumes (NIfTI-1, .nii or .nii.gz) by deforming\n"
    "a sphere mesh that never flips or self-intersects.\n"
    "\n"
    "commands:\n"
    "  segment VOLUME --sphere X,Y,Z,R --out DIR   grow spheres into objects; write\n"
    "                                               meshes, labels, overlay, report\n"
    "  info VOLUME                                  header, grid, affine, intensities\n"
    "  eval PRED TRUTH [--labels a,b:c,...]         Dice, VOE, ASSD, HD95 per label\n"
    "\n"
    "options:\n"
    "  -h, --help       this text (ffseg COMMAND --help: that command's options)\n"
    "  --version        program and library version\n"
    "\n"
    "exit status: 0 success, 1 an output could not be written, 2 usage error,\n"
    "3 unreadable or malformed input, 4 engine error, 5 no object found (segment: no\n"
    "boundary ever met, or an object fills most of the grid), 6 an object stalled short of\n"
    "its boundary (segment: outputs written, warned about), 130 interrupted.\n";

std::string version_string(uint32_t v) {
  return std::to_string(v / 10000) + "." + std::to_string(v / 100 % 100) + "." + std::to_string(v % 100);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ffseg_cli;
  try {
    if (argc < 2) fail(kExitUsage, "missing COMMAND: segment, info or eval (see 'ffseg --help')");
    const std::string cmd = argv[1];
    if (cmd == "-h" || cmd == "--help" || cmd == "help") {
      if (cmd == "help" && argc > 2) {
        const std::string sub = argv[2];
        if (sub == "segment") { std::fputs(segment_usage().c_str(), stdout); return kExitOk; }
        if (sub == "info") { std::fputs(kInfoUsage, stdout); return kExitOk; }
        if (sub == "eval") { std::fputs(kEvalUsage, stdout); return kExitOk; }
        fail(kExitUsage, "unknown command '" + sub + "' (commands: segment, info, eval)");
      }
      std::fputs(kMainUsage, stdout);
      return kExitOk;
    }
    if (cmd == "--version" || cmd == "-V") {
      const uint32_t lib = ffseg_version_number();
      std::printf("ffseg %s (library %s)\n", version_string(FFSEG_VERSION_NUMBER).c_str(),
                  version_string(lib).c_str());
      return kExitOk;
    }
    if (ffseg_version_number() / 100 != FFSEG_VERSION_NUMBER / 100)
      fail(kExitEngine, "library version " + version_string(ffseg_version_number()) +
                            " does not match the header's " + version_string(FFSEG_VERSION_NUMBER));
    if (cmd == "segment") return cmd_segment(argc, argv);
    if (cmd == "info") return cmd_info(argc, argv);
    if (cmd == "eval") return cmd_eval(argc, argv);
    if (!cmd.empty() && cmd[0] == '-') fail(kExitUsage, "unknown option '" + cmd + "' (try ffseg --help)");
    fail(kExitUsage, "unknown command '" + cmd + "' (commands: segment, info, eval; try ffseg --help)");
  } catch (const CliError& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "ffseg: error: %s\n", e.message.c_str());
    return e.code;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "ffseg: error: out of memory\n");
    return kExitFailure;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffseg: error: %s\n", e.what());
    return kExitFailure;
  }
}
