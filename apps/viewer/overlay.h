// The on-screen help and statistics (H): lines of text drawn with SDL2_ttf in a Debian font over
// the top-left corner of the window. Only the window shows it; screenshots are the rendered image.
#pragma once

#include <SDL.h>
#include <SDL_ttf.h>

#include <string>
#include <vector>

namespace tritrace::view {

class Overlay {
 public:
  explicit Overlay(std::string font_path) : font_path_(std::move(font_path)) {}
  ~Overlay();
  Overlay(const Overlay&) = delete;
  Overlay& operator=(const Overlay&) = delete;

  // Draws `lines`, rasterising them again only when they changed. The font is opened on first
  // use; when it cannot be, one warning line goes to stderr and nothing is drawn.
  void draw(SDL_Renderer* renderer, const std::vector<std::string>& lines);

 private:
  bool open_font();

  std::string font_path_;
  bool tried_ = false;
  bool ttf_ready_ = false;
  TTF_Font* font_ = nullptr;
  SDL_Texture* texture_ = nullptr;
  int width_ = 0, height_ = 0;
  std::vector<std::string> drawn_;
};

}  // namespace tritrace::view
