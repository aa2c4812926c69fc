#pragma once
// rgbdmap run --viewer [PORT]: the live map viewer (apps/viewer) inside the all-in-one job. It subscribes to
// the map streams on the server's memq:// bus, or on a transport instance of its own for lcm/dds (as a
// separate rgbdmap-viewer would), serves http://127.0.0.1:PORT/ during the run and stays open after it,
// with the final map, until Ctrl-C.
#include <memory>
#include <string>
#include <vector>

#include "local_deployment.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/viewer/viewer.hpp"
#include "run_plan.hpp"

namespace rgbdmap::cmd {

/// argv with a bare `--viewer` (last, or followed by another option) given its default port, so that
/// cli::Args reads `--viewer [PORT]` as an option with a value.
class ViewerArgv {
 public:
  ViewerArgv(int argc, char** argv);
  int argc() const { return static_cast<int>(pointers_.size()); }
  char** argv() { return pointers_.data(); }

 private:
  std::vector<std::string> args_;
  std::vector<char*> pointers_;
};

/// The port of --viewer (-1 without it); a bad value is appended to *errors.
int viewerPort(cli::Args& args, std::vector<std::string>* errors);

/// The viewer of a run and its own transport (none on memq://).
struct RunViewer {
  std::unique_ptr<transport::Transport> transport;
  std::unique_ptr<viewer::Viewer> viewer;
  ~RunViewer();
};

/// `record_path`: non-empty, the viewer's topics also go into this MCAP file (ViewerOptions::record_path).
Result<std::unique_ptr<RunViewer>> startRunViewer(int port, const std::string& record_path,
                                                  const std::string& transport_url,
                                                  const std::vector<RobotPlan>& plans,
                                                  LocalDeployment& deployment);

/// Logs where the viewer is and blocks until SIGINT or SIGTERM.
void keepViewerOpen(const RunViewer& run_viewer);

}  // namespace rgbdmap::cmd
