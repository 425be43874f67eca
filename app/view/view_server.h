// mcpt view's web server: one page (embedded in the binary) and a small API over a
// LiveRender, served by cpp-httplib on its own threads.
//
//   GET  /                      the page
//   GET  /api/state             JSON: sides, sample counts, speeds, errors, the error curves
//   GET  /api/frame?side=S&since=N
//                               side S's latest image (204 when it is still snapshot N)
//   GET  /api/pixel?x=X&y=Y     JSON: that pixel's radiance, standard error and samples on
//                               every side, and its z and relative difference
//   GET  /api/maps?since=SPP    A/B: the z and divergence maps (204 when unchanged)
//   GET  /api/save?side=S&format=exr|png
//                               the image as a file
//   POST /api/pause, /api/resume, /api/reset
// Anything else is 404: the server serves no files from disk. Every request needs the run's
// token and this viewer's Host (view_access.h); connections are bounded (guarded_server.h).
//
// Frames and maps are binary: a uint32 (little-endian) byte count of a JSON header, the
// header (padded with spaces to a multiple of 4 bytes), then the data, top row first. Frames,
// to display (about 5 bytes a pixel, so that watching costs little): RGBE radiance, then a
// byte of relative error per pixel (view_server.cpp, frame_body). Maps: float32 z and
// relative difference, interleaved.
#pragma once
#include <memory>
#include <string>

#include "app/view/view_access.h"
#include "common/view/live_render.h"

namespace mcpt {

struct ViewInfo {
    std::string scene;                // shown as the title
    std::string sides[2] = {"", ""};  // "A: opencl ..." for A/B runs, else the device
};

class GuardedServer;

class ViewServer {
  public:
    // Serves on `listen` (an address of this machine; its Host names are the ones accepted).
    ViewServer(LiveRender& live, ViewInfo info, const std::string& listen);
    ~ViewServer();
    // Binds the address on `port` (0: any free one); returns the port. A port in use is an
    // error (no SO_REUSEPORT). Throws mcpt::Error.
    int bind(int port);
    // The address to open, with the token.
    std::string url() const { return access_.url(); }
    // Serves until stop() (from another thread).
    void serve();
    void stop();
    // Frames sent so far (all sides), for the command's summary.
    uint64_t frames_sent() const;

  private:
    std::string state_json();
    LiveRender& live_;
    ViewInfo info_;
    std::string listen_;
    ViewAccess access_;
    std::unique_ptr<GuardedServer> server_;
    std::atomic<uint64_t> frames_{0};
};

}  // namespace mcpt
