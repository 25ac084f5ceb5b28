// How the lecturer's mouse and keys move a view (posenav, docs/network.md): dragging with the left button
// looks around, the wheel and the arrow/WASD keys walk level along the heading, Q/E or PageUp/PageDown move
// up and down, Home or R returns to the start view. GStreamer-free: posenav parses the video sink's
// navigation events and hands their buttons, positions and keys to this.
#pragma once

#include <string>

#include <gst/vclassroom/core/view_offset.h>

namespace vclassroom {

// What an input did: not a navigation input (it goes on to whoever else wants it), taken without changing
// the view (a drag's start, a key's release), or the view moved.
enum class Navigated { kNotOurs, kTaken, kMoved };

class ViewNavigator {
 public:
  static constexpr double kDefaultMoveStep = 0.1;   // m per key press or wheel notch
  static constexpr double kDefaultTurnSpeed = 0.2;  // degrees per dragged pixel

  double move_step = kDefaultMoveStep;
  double turn_speed = kDefaultTurnSpeed;
  ViewOffset start;  // where Home or R returns to
  ViewOffset view;   // the current view

  // A mouse button pressed or released at (x, y). Button 1 drags; X11 sinks (xvimagesink, ximagesink)
  // report a wheel notch as a press of button 4 (away from you) or 5 (towards you), never as a scroll.
  Navigated press(int button, double x, double y);
  Navigated release(int button);
  // The pointer at (x, y): while dragging, right turns right and up looks up.
  Navigated pointer_move(double x, double y);
  // A wheel scrolled by `dy` notches: away from you (positive) walks forward.
  Navigated scroll(double dy);
  Navigated key_press(const std::string& key);
  // The release of a key whose press moved is taken too, and changes nothing.
  Navigated key_release(const std::string& key);
  // Forgets a drag in progress (a new stream).
  void end_drag() { dragging_ = false; }

 private:
  // Moving follows the heading (yaw) but stays level, as walking does.
  void walk(double forward, double right);

  bool dragging_ = false;
  double drag_x_ = 0, drag_y_ = 0;
};

}  // namespace vclassroom
