// rs-discover doctor ID: the one camera a user asks about. Whether the daemon lists it
// (or why it left), and who uses it: a network camera streamed to another client locks
// the profiles of what it streams, so a new open-streams asking others is refused; a
// USB camera's holders are the processes with its nodes open (usb_holders.hpp).
#include "doctor.hpp"
#include "usb_holders.hpp"

#include <algorithm>
#include <chrono>

namespace rsdiscover::doctor {
namespace {

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

std::string camera_name(const rsdiscovery::Device& d) {
  std::string out = d.name.empty() ? d.id : d.name;
  if (!d.serial.empty()) out += " " + d.serial;
  return out;
}

// "depth-viewer (viewer.py@lab-2) at 10.0.0.7": who a client is and where it runs.
std::string client_name(const rsdiscovery::CameraClient& c) {
  // A ROS 2 node's participant is named "/": its nodes say who it is.
  std::string out = "'" + (!c.ros_nodes.empty() ? joined(c.ros_nodes) : c.name.empty() ? c.guid : c.name) + "'";
  if (!c.process.empty() || !c.host.empty())
    out += " (" + c.process + (c.host.empty() ? "" : (c.process.empty() ? "" : "@") + c.host) + ")";
  if (!c.addresses.empty()) out += " at " + joined(c.addresses);
  return out;
}

void check_dds_clients(Report& r, rsdiscovery::Client& client, const rsdiscovery::Device& d) {
  const auto found = client.clients(d.id);
  bool streamed = false;
  for (const auto& c : found.clients) {
    if (c.streams.empty()) continue;
    streamed = true;
    // realdds commits a sensor's profiles when it starts streaming and keeps them until
    // its last reader goes (dds-stream-sensor-bridge.cpp; the D555's own server answers
    // "Sensor is streaming"): reading the same profiles beside it works, others do not.
    r.add(Verdict::warn, "in-use",
          camera_name(d) + " streams " + joined(c.streams) + " to " + client_name(c) +
              ": a new open-streams asking other profiles of " + (c.streams.size() == 1 ? "that stream" : "those streams") +
              " is refused until it stops; open the same profiles, or stop that client first");
  }
  if (streamed) return;
  if (!found.clients.empty()) {
    std::vector<std::string> who;
    for (const auto& c : found.clients) who.push_back(client_name(c));
    r.add(Verdict::info, "in-use",
          camera_name(d) + " has " + std::to_string(who.size()) + (who.size() == 1 ? " client" : " clients") + " (" +
              joined(who) + "), none streaming: any profile can be opened");
    return;
  }
  r.add(Verdict::ok, "in-use", camera_name(d) + " has no client: it is free to open and stream");
}

void check_usb_holders(Report& r, const rsdiscovery::Device& d) {
  const auto doc = rsdiscovery::json::parse_or_null(d.json);
  const auto* usb = rsdiscovery::json::find(doc, "usb");
  const auto found = find_usb_holders(rsdiscovery::json::texts(rsdiscovery::json::find(usb, "device-nodes")));
  for (const auto& h : found.holders)
    r.add(Verdict::info, "in-use",
          camera_name(d) + " is held open by pid " + std::to_string(h.pid) + " (" + h.user + ": " + h.command +
              ") through " + joined(h.nodes) +
              ": while it streams, another program's open of it fails with 'Device or resource busy'");
  const std::string unread = found.unreadable == 0 ? ""
                                                   : " among the processes readable here (" +
                                                         std::to_string(found.unreadable) +
                                                         " of other users were not: run as root to see all)";
  if (found.holders.empty())
    r.add(found.unreadable == 0 ? Verdict::ok : Verdict::info, "in-use",
          camera_name(d) + " is held open by no process" + unread);
}

// Whether the camera sent its whole notification set when the daemon asked (the
// device's "ready"): a camera listed but not ready is one librealsense finds and
// then gives up on, which users report as "found but never ready".
void check_ready(Report& r, rsdiscovery::Client& client, rsdiscovery::Device& d) {
  if (d.field("ready").empty() && d.field("recovery") != "true") {
    // Not asked yet (describe-eagerly is off and no one described it): asked now, as
    // librealsense would open it. The daemon says `ready` once the set came whole, or
    // librealsense's 5 s wait is over; a set that never completes keeps the
    // description waiting longer, so the wait here is that one and a margin.
    try {
      client.describe(d.id, std::chrono::milliseconds(7000));
    } catch (const rsdiscovery::Error&) {
    }
    try {
      d = client.get_device(d.id);
    } catch (const rsdiscovery::Error&) {
      return;  // gone meanwhile: the history lines say why
    }
  }
  const std::string ready = d.field("ready");
  if (ready.empty()) return;  // still not known (an older daemon)
  if (ready == "true") {
    r.add(Verdict::ok, "ready", camera_name(d) + " sent its whole description when asked: it is ready");
    return;
  }
  const auto stage = rsdiscovery::json::parse_or_null(d.field("ready-stage"));
  r.add(Verdict::warn, "ready",
        camera_name(d) + " is listed but not ready: its server's notification set stopped at " +
            rsdiscovery::json::text_or(&stage, "an unknown stage") +
            ". librealsense waits 5 s for that set, then gives the camera up (\"timeout waiting to get ready\"); "
            "the daemon asks again, less and less often. Restart the camera's server (power-cycle a PoE camera); "
            "if it happens on one network only, look for lost samples there (MTU, a switch dropping fragments)");
}

}  // namespace

void check_camera(Report& r, rsdiscovery::Client& client, const std::string& id) {
  rsdiscovery::Device d;
  try {
    d = client.get_device(id);
  } catch (const rsdiscovery::Error& e) {
    if (e.code() != rsdiscovery::ErrorCode::not_found) throw;
    r.add(Verdict::fail, "camera", std::string(e.what()) + ": the lines below say why cameras go missing");
    return;
  }
  r.add(Verdict::ok, "camera", camera_name(d) + " is listed as " + d.id + " (" + d.state + ")");
  if (d.domain) {
    check_ready(r, client, d);
    check_dds_clients(r, client, d);
  }
  const bool usb = d.source == "usb" || std::find(d.sources.begin(), d.sources.end(), "usb") != d.sources.end();
  if (usb) check_usb_holders(r, d);
}

}  // namespace rsdiscover::doctor
