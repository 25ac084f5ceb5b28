#include "view_navigator.h"

#include <algorithm>
#include <cmath>

namespace vclassroom {

void ViewNavigator::walk(double forward, double right) {
  const double yaw = view.yaw * M_PI / 180.0;
  view.forward += forward * std::cos(yaw) - right * std::sin(yaw);
  view.right += forward * std::sin(yaw) + right * std::cos(yaw);
}

Navigated ViewNavigator::press(int button, double x, double y) {
  if (button == 4 || button == 5) {
    walk(button == 4 ? move_step : -move_step, 0);
    return Navigated::kMoved;
  }
  if (button != 1) return Navigated::kNotOurs;
  dragging_ = true;
  drag_x_ = x;
  drag_y_ = y;
  return Navigated::kTaken;
}

Navigated ViewNavigator::release(int button) {
  if (button == 4 || button == 5) return Navigated::kTaken;  // the wheel's press moved already
  if (button != 1) return Navigated::kNotOurs;
  dragging_ = false;
  return Navigated::kTaken;
}

Navigated ViewNavigator::pointer_move(double x, double y) {
  if (!dragging_) return Navigated::kNotOurs;
  view.yaw += (x - drag_x_) * turn_speed;
  view.pitch = std::clamp(view.pitch - (y - drag_y_) * turn_speed, -89.0, 89.0);
  drag_x_ = x;
  drag_y_ = y;
  return Navigated::kMoved;
}

Navigated ViewNavigator::scroll(double dy) {
  walk(dy * move_step, 0);
  return Navigated::kMoved;
}

Navigated ViewNavigator::key_press(const std::string& k) {
  if (k == "Up" || k == "w") walk(move_step, 0);
  else if (k == "Down" || k == "s") walk(-move_step, 0);
  else if (k == "Left" || k == "a") walk(0, -move_step);
  else if (k == "Right" || k == "d") walk(0, move_step);
  else if (k == "Page_Up" || k == "q") view.up += move_step;
  else if (k == "Page_Down" || k == "e") view.up -= move_step;
  else if (k == "Home" || k == "r") view = start;
  else return Navigated::kNotOurs;
  return Navigated::kMoved;
}

Navigated ViewNavigator::key_release(const std::string& key) {
  static const char* const ours[] = {"Up", "Down", "Left", "Right", "w", "s", "a", "d", "Page_Up", "Page_Down",
                                     "q", "e", "Home", "r"};
  for (const char* k : ours)
    if (key == k) return Navigated::kTaken;
  return Navigated::kNotOurs;
}

}  // namespace vclassroom
