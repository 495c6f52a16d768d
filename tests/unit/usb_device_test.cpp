// The pure parts of the USB source: product table, ids, the device document, sysfs.
#include "usb/realsense_ids.hpp"
#include "usb/usb_device.hpp"

#include "rsd_model/device.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

using namespace rsd::usb;
namespace fs = std::filesystem;

namespace {
UsbSighting d455_on(double mbps) {
  UsbSighting s;
  s.vid = 0x8086;
  s.pid = 0x0B5C;
  s.bcd_usb = 0x0320;
  s.bus = 2;
  s.address = 7;
  s.ports = {1, 4};
  s.speed_mbps = mbps;
  s.serial = "123622270732";
  s.sysfs_path = "/sys/devices/pci0000:00/0000:00:14.0/usb2/2-1/2-1.4";
  return s;
}
}  // namespace

TEST(RealsenseIds, KnownCamerasOtherIntelDevicesAndOtherVendors) {
  const auto* d455 = find_product(0x8086, 0x0B5C);
  ASSERT_NE(d455, nullptr);
  EXPECT_STREQ(d455->name, "D455");
  EXPECT_STREQ(d455->product_line, "D400");
  EXPECT_FALSE(d455->recovery);
  EXPECT_TRUE(d455->usb3);
  const auto* rec = find_product(0x8086, 0x0ADB);
  ASSERT_NE(rec, nullptr);
  EXPECT_TRUE(rec->recovery);
  EXPECT_STREQ(find_product(0x8086, 0x0ADE)->product_line, "D500");
  EXPECT_STREQ(find_product(0x8086, 0x0B64)->product_line, "L500");
  EXPECT_STREQ(find_product(0x8086, 0x0B37)->product_line, "T200");
  EXPECT_STREQ(find_product(0x8086, 0x0AA5)->product_line, "SR300");
  EXPECT_EQ(find_product(0x8086, 0x0A2B), nullptr);  // an Intel Bluetooth controller
  EXPECT_EQ(find_product(0x1234, 0x0B5C), nullptr);
}

TEST(UsbDevice, PortPathsAndSpeeds) {
  EXPECT_EQ(port_path(2, {1, 4}), "2-1.4");
  EXPECT_EQ(port_path(1, {3}), "1-3");
  EXPECT_EQ(port_path(3, {}), "usb3");
  EXPECT_EQ(speed_name(0), "unknown");
  EXPECT_EQ(speed_name(1.5), "low");
  EXPECT_EQ(speed_name(12), "full");
  EXPECT_EQ(speed_name(480), "high");
  EXPECT_EQ(speed_name(5000), "super");
  EXPECT_EQ(speed_name(10000), "super-plus");
  EXPECT_EQ(speed_name(20000), "super-plus");
}

TEST(UsbDevice, SerialsAreCleanedOrRefused) {
  EXPECT_EQ(clean_serial("123622270732\n"), "123622270732");
  EXPECT_EQ(clean_serial("  AB12 \n"), "AB12");
  EXPECT_EQ(clean_serial(""), std::nullopt);
  EXPECT_EQ(clean_serial("\n"), std::nullopt);
  EXPECT_EQ(clean_serial(std::string("12\x01" "3")), std::nullopt);
  EXPECT_EQ(clean_serial("caf\xc3\xa9"), std::nullopt);
  EXPECT_EQ(clean_serial(std::string(65, '1')), std::nullopt);
}

TEST(UsbDevice, IdsAreStableAndUrlSafe) {
  auto s = d455_on(5000);
  EXPECT_EQ(sighting_id(s), "usb-123622270732");
  s.serial = "A B/C?";
  EXPECT_EQ(sighting_id(s), "usb-A_B_C_");
  s.serial.reset();
  EXPECT_EQ(sighting_id(s), "usb-port-2-1.4");
  EXPECT_EQ(url_safe("a-b_c.d~e"), "a-b_c.d~e");
}

TEST(UsbDevice, DocumentOfAUsb3CameraOnUsb3) {
  const auto s = d455_on(5000);
  const auto doc = to_json(s, *find_product(s.vid, s.pid));
  EXPECT_EQ(doc["source"], "usb");
  EXPECT_EQ(doc["name"], "Intel RealSense D455");
  EXPECT_EQ(doc["serial"], "123622270732");
  EXPECT_EQ(doc["product-id"], "0B5C");
  EXPECT_EQ(doc["product-line"], "D400");
  EXPECT_EQ(doc["recovery"], false);
  EXPECT_EQ(doc["usb"]["bus"], 2);
  EXPECT_EQ(doc["usb"]["address"], 7);
  EXPECT_EQ(doc["usb"]["port-path"], "2-1.4");
  EXPECT_EQ(doc["usb"]["speed"], "super");
  EXPECT_EQ(doc["usb"]["speed-mbps"], 5000);
  EXPECT_EQ(doc["usb"]["vid"], "8086");
  EXPECT_EQ(doc["usb"]["pid"], "0B5C");
  EXPECT_EQ(doc["usb"]["usb-version"], "3.20");
  EXPECT_EQ(doc["usb"]["sysfs-path"], s.sysfs_path);
  EXPECT_FALSE(doc["usb"].contains("device-nodes"));  // none found: not written
  EXPECT_FALSE(doc.contains("warnings"));
  EXPECT_FALSE(doc.contains("id"));  // the table sets it
}

TEST(UsbDevice, Usb3CameraOnUsb2IsWarnedAbout) {
  auto s = d455_on(480);
  s.bcd_usb = 0x0210;
  const auto doc = to_json(s, *find_product(s.vid, s.pid));
  ASSERT_TRUE(doc.contains("warnings"));
  const std::string w = doc["warnings"][0];
  EXPECT_NE(w.find("USB 2"), std::string::npos);
  EXPECT_NE(w.find("480 Mbit/s"), std::string::npos);
  EXPECT_EQ(doc["usb"]["speed"], "high");
}

TEST(UsbDevice, NoWarningForRecoveryUsb2VariantOrUnknownSpeed) {
  auto s = d455_on(480);
  s.pid = 0x0ADC;
  EXPECT_EQ(link_warning(s, *find_product(s.vid, s.pid)), std::nullopt);
  const auto doc = to_json(s, *find_product(s.vid, s.pid));
  EXPECT_EQ(doc["recovery"], true);
  EXPECT_EQ(doc["name"], "Intel RealSense D4XX USB2 Recovery");
  s.pid = 0x0AD6;
  EXPECT_EQ(link_warning(s, *find_product(s.vid, s.pid)), std::nullopt);
  s = d455_on(0);
  EXPECT_EQ(link_warning(s, *find_product(s.vid, s.pid)), std::nullopt);
  EXPECT_FALSE(to_json(s, *find_product(s.vid, s.pid))["usb"].contains("speed-mbps"));
}

class Sysfs : public ::testing::Test {
 protected:
  void SetUp() override {
    root = fs::temp_directory_path() / ("rsd-sysfs-" + std::to_string(::getpid()));
    fs::remove_all(root);
    dev = root / "devices/pci0000:00/0000:00:14.0/usb2/2-1/2-1.4";
    fs::create_directories(dev);
    fs::create_directories(root / "bus/usb/devices");
    fs::create_directory_symlink("../../../devices/pci0000:00/0000:00:14.0/usb2/2-1/2-1.4",
                                 root / "bus/usb/devices/2-1.4");
    write("busnum", "2\n");
    write("devnum", "7\n");
    write("serial", "123622270732\n");
    write("speed", "5000\n");
  }
  void TearDown() override { fs::remove_all(root); }
  void write(const char* name, const std::string& text) { std::ofstream(dev / name) << text; }
  fs::path root, dev;
};

TEST_F(Sysfs, ReadsSerialSpeedAndRealPath) {
  const auto info = read_sysfs(root.string(), 2, {1, 4}, 7);
  ASSERT_TRUE(info.matches);
  EXPECT_EQ(info.serial, "123622270732");
  EXPECT_EQ(info.speed_mbps, 5000);
  EXPECT_EQ(info.path, (root / "devices/pci0000:00/0000:00:14.0/usb2/2-1/2-1.4").string());
}

TEST_F(Sysfs, AnotherDeviceAtThatPortIsNotTrusted) {
  EXPECT_FALSE(read_sysfs(root.string(), 2, {1, 4}, 8).matches);  // replugged: new devnum
  EXPECT_FALSE(read_sysfs(root.string(), 2, {1, 5}, 7).matches);  // no such port
}

TEST_F(Sysfs, LowSpeedAndMissingOrBadSerial) {
  write("speed", "1.5\n");
  fs::remove(dev / "serial");
  auto info = read_sysfs(root.string(), 2, {1, 4}, 7);
  ASSERT_TRUE(info.matches);
  EXPECT_EQ(info.speed_mbps, 1.5);
  EXPECT_EQ(info.serial, std::nullopt);
  write("serial", std::string("\xff\xfe\n"));
  write("speed", "fast\n");
  info = read_sysfs(root.string(), 2, {1, 4}, 7);
  EXPECT_EQ(info.serial, std::nullopt);
  EXPECT_EQ(info.speed_mbps, 0);
}

// A camera's tree as the kernel lays it out once uvcvideo and usbhid have bound.
TEST_F(Sysfs, DeviceNodesOfItsInterfacesAndNotOfADeviceBelowIt) {
  write("uevent", "MAJOR=189\nMINOR=134\nDEVNAME=bus/usb/002/007\nDEVTYPE=usb_device\n");
  const auto node = [&](const std::string& dir, const std::string& devname) {
    fs::create_directories(dev / dir);
    std::ofstream(dev / dir / "uevent") << "MAJOR=81\nDEVNAME=" << devname << "\n";
  };
  node("2-1.4:1.0/video4linux/video2", "video2");
  node("2-1.4:1.0/video4linux/video0", "video0");
  node("2-1.4:1.0/media1", "media1");
  node("2-1.4:1.5/0003:8086:0B5C.0004/hidraw/hidraw3", "hidraw3");
  node("2-1.4:1.5/0003:8086:0B5C.0004/input/input9/event9", "input/event9");  // not the camera's to hold
  fs::create_directories(dev / "2-1.4:1.0/video4linux/video5");  // no uevent: no node
  // A device on a port below it (were it a hub) is its own camera.
  fs::create_directories(dev / "2-1.4.1/2-1.4.1:1.0/video4linux/video7");
  std::ofstream(dev / "2-1.4.1/devnum") << "9\n";
  std::ofstream(dev / "2-1.4.1/2-1.4.1:1.0/video4linux/video7/uevent") << "DEVNAME=video7\n";
  EXPECT_EQ(device_nodes(dev.string(), 2, 7),
            (std::vector<std::string>{"/dev/bus/usb/002/007", "/dev/hidraw3", "/dev/media1", "/dev/video0",
                                      "/dev/video2"}));
  // Without a uevent of its own, the usbfs node is named from bus and address.
  fs::remove(dev / "uevent");
  fs::remove_all(dev / "2-1.4:1.0");
  fs::remove_all(dev / "2-1.4:1.5");
  EXPECT_EQ(device_nodes(dev.string(), 2, 7), std::vector<std::string>{"/dev/bus/usb/002/007"});
  EXPECT_TRUE(device_nodes("", 2, 7).empty());
  EXPECT_TRUE(device_nodes((root / "devices/gone").string(), 2, 7).empty());  // unplugged meanwhile
}

TEST(UsbDevice, DeviceNodesAreInTheDocumentAndRoundTrip) {
  auto s = d455_on(5000);
  s.device_nodes = {"/dev/bus/usb/002/007", "/dev/video0"};
  const auto doc = to_json(s, *find_product(s.vid, s.pid));
  EXPECT_EQ(doc["usb"]["device-nodes"], nlohmann::json::array({"/dev/bus/usb/002/007", "/dev/video0"}));
  const auto d = rsd::model::device_from_json(doc);
  ASSERT_TRUE(d.usb);
  EXPECT_EQ(d.usb->device_nodes, s.device_nodes);
  EXPECT_EQ(rsd::model::to_json(d), doc);
}
