#pragma once
// A headless OpenGL 3.3 core context on EGL with no window system (Mesa's surfaceless
// platform; llvmpipe where there is no GPU), rendering into an offscreen framebuffer that
// can be read back and written as a PNG.
#include <cstdint>
#include <string>
#include <vector>

namespace ffd::ui {

class HeadlessGl {
 public:
  // Throws std::runtime_error saying what EGL refused.
  HeadlessGl(int width, int height);
  ~HeadlessGl();
  HeadlessGl(const HeadlessGl&) = delete;
  HeadlessGl& operator=(const HeadlessGl&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }
  void bind();  // makes the context current and binds the offscreen framebuffer
  // RGBA pixels of the framebuffer, top row first, opaque (as a window shows them).
  std::vector<std::uint8_t> read_pixels() const;
  std::string renderer() const;  // GL_RENDERER, GL_VERSION

 private:
  int width_, height_;
  void* display_ = nullptr;
  void* context_ = nullptr;
  unsigned framebuffer_ = 0, colour_ = 0, depth_ = 0;
};

// Writes RGBA pixels (top row first) as a PNG; throws naming the path on failure.
void write_png(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgba);

}  // namespace ffd::ui
