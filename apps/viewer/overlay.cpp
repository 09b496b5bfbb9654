// Text is rasterised into one surface, turned into a texture, and drawn over a translucent panel
// so it stays legible over any part of the image.
#include "overlay.h"

#include <algorithm>
#include <cstdio>

namespace tritrace::view {
namespace {

constexpr int kFontPoints = 14;
constexpr int kMargin = 8;

}  // namespace

Overlay::~Overlay() {
  if (texture_ != nullptr) SDL_DestroyTexture(texture_);
  if (font_ != nullptr) TTF_CloseFont(font_);
  if (ttf_ready_) TTF_Quit();
}

bool Overlay::open_font() {
  if (tried_) return font_ != nullptr;
  tried_ = true;
  if (TTF_Init() != 0) {
    std::fprintf(stderr, "tritrace-view: SDL_ttf: cannot start, no overlay: %s\n", TTF_GetError());
    return false;
  }
  ttf_ready_ = true;
  font_ = TTF_OpenFont(font_path_.c_str(), kFontPoints);
  if (font_ == nullptr) {
    std::fprintf(stderr, "tritrace-view: %s: cannot open the overlay's font: %s\n",
                 font_path_.c_str(), TTF_GetError());
  }
  return font_ != nullptr;
}

void Overlay::draw(SDL_Renderer* renderer, const std::vector<std::string>& lines) {
  if (!open_font()) return;
  if (texture_ == nullptr || lines != drawn_) {
    if (texture_ != nullptr) SDL_DestroyTexture(texture_);
    texture_ = nullptr;
    drawn_ = lines;
    const int line_height = TTF_FontLineSkip(font_);
    int width = 1;
    for (const std::string& line : lines) {
      int w = 0, h = 0;
      if (TTF_SizeUTF8(font_, line.c_str(), &w, &h) == 0) width = std::max(width, w);
    }
    const int height = std::max(1, line_height * static_cast<int>(lines.size()));
    SDL_Surface* panel =
        SDL_CreateRGBSurfaceWithFormat(0, width, height, 32, SDL_PIXELFORMAT_ARGB8888);
    if (panel == nullptr) return;
    SDL_FillRect(panel, nullptr, SDL_MapRGBA(panel->format, 0, 0, 0, 0));
    const SDL_Color white{255, 255, 255, 255};
    for (size_t i = 0; i < lines.size(); ++i) {
      if (lines[i].empty()) continue;
      SDL_Surface* text = TTF_RenderUTF8_Blended(font_, lines[i].c_str(), white);
      if (text == nullptr) continue;
      SDL_Rect at{0, static_cast<int>(i) * line_height, text->w, text->h};
      SDL_BlitSurface(text, nullptr, panel, &at);
      SDL_FreeSurface(text);
    }
    texture_ = SDL_CreateTextureFromSurface(renderer, panel);
    SDL_FreeSurface(panel);
    if (texture_ == nullptr) return;
    SDL_SetTextureBlendMode(texture_, SDL_BLENDMODE_BLEND);
    width_ = width;
    height_ = height;
  }
  const SDL_Rect back{0, 0, width_ + 2 * kMargin, height_ + 2 * kMargin};
  SDL_SetRenderDrawBlendMode(renderer, SDL_BLENDMODE_BLEND);
  SDL_SetRenderDrawColor(renderer, 0, 0, 0, 170);
  SDL_RenderFillRect(renderer, &back);
  const SDL_Rect at{kMargin, kMargin, width_, height_};
  SDL_RenderCopy(renderer, texture_, nullptr, &at);
}

}  // namespace tritrace::view
