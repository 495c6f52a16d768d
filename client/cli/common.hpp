// What every rs-discover subcommand shares: option parsing (options.cpp), the client,
// filters, errors and exit codes (daemon_client.cpp), tables, colour and times
// (output.cpp), --format templates (format_template.cpp). One subcommand per
// cmd_*.cpp file.
#pragma once

#include <rsdiscovery/rsdiscovery.hpp>

#include "json.hpp"

#include <cstdio>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace rsdiscover {

// Exit codes (documented in --help and rs-discover.1).
enum Exit : int {
  kOk = 0,
  kNotFound = 1,     // no such device, or a wait/timeout ran out
  kUsage = 2,        // bad command line
  kUnreachable = 3,  // the daemon is not running or may not be reached
  kBadReply = 4,     // the daemon answered something this client does not understand
};

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct OptionSpec {
  const char* name;   // long name without "--"
  char short_name;    // 0: none
  const char* value;  // nullptr: a flag; else the value's name in help
  const char* help;
};

// Options every subcommand takes.
extern const std::vector<OptionSpec> kCommonOptions;
// The wait for the daemon's complete table (list and get; make_client() reads them).
// constexpr, so the commands' option tables, built at static initialisation in
// other files, never copy them before they exist.
inline constexpr OptionSpec kNoWaitCompleteOption = {
    "no-wait-complete", 0, nullptr,
    "answer at once, even while the daemon's first discovery still runs (cameras may be missing)"};
inline constexpr OptionSpec kCompleteTimeoutOption = {
    "complete-timeout", 0, "S",
    "wait at most S seconds (default 5) for the daemon's first discovery to end"};

// The device filters of list and watch (the daemon applies them: GET /v1/devices).
inline constexpr OptionSpec kDomainOption = {"domain", 'd', "N", "only devices on DDS domain N (repeat for several)"};
inline constexpr OptionSpec kProductLineOption = {"product-line", 'p', "LINE",
                                                  "only devices of this product line (D400, D500, ...)"};
inline constexpr OptionSpec kSourceOption = {"source", 's', "SOURCE", "only devices seen this way: dds, usb or remote-usb (another host's USB)"};
inline constexpr OptionSpec kSerialOption = {"serial", 0, "SERIAL", "only the device with this serial number"};
inline constexpr OptionSpec kNameOption = {"name", 'n', "TEXT", "only devices whose name contains TEXT (any case)"};
inline constexpr OptionSpec kAddressOption = {"address", 'a', "ADDR",
                                              "only network cameras whose server has this address"};
inline constexpr OptionSpec kHostOption = {
    "host", 0, "NAME", "only the USB cameras the daemon on host NAME shares (remote-usb; any case)"};
inline constexpr OptionSpec kInUseOption = {
    "in-use", 0, nullptr, "only network cameras a client uses now ('rs-discover clients ID' says who)"};
inline constexpr OptionSpec kFreeOption = {"free", 0, nullptr,
                                           "only cameras no network client uses (USB cameras too)"};
// `own` with the device filters above in front: list's and watch's options.
std::vector<OptionSpec> with_device_filters(std::vector<OptionSpec> own);
inline constexpr OptionSpec kNoHeadersOption = {"no-headers", 'H', nullptr, "print the table without its header line"};

struct ParsedArgs {
  std::map<std::string, std::string> values;  // the last value of each option; flags map to "1"
  std::map<std::string, std::vector<std::string>> all;  // every value, in order (repeated options)
  std::vector<std::string> positional;
  bool has(const std::string& name) const { return values.count(name) > 0; }
  std::string get(const std::string& name, const std::string& fallback = "") const;
  int get_int(const std::string& name, int fallback, int min, int max) const;
  double get_seconds(const std::string& name, double fallback) const;
  // Every value of a repeated whole-number option, each checked as get_int does.
  std::vector<int> get_ints(const std::string& name, int min, int max) const;
};

// Parses `args` (after the subcommand's name) against `specs` plus the common ones.
ParsedArgs parse_args(const std::vector<std::string>& args, const std::vector<OptionSpec>& specs);

struct Command {
  const char* name;
  const char* summary;
  const char* usage;        // the line after "Usage: rs-discover "
  const char* description;  // a paragraph
  std::vector<OptionSpec> options;
  int (*run)(const ParsedArgs& args);
};

void print_help(const Command& command, std::FILE* out);

// Output context, set from the common options.
struct Output {
  bool color = false;
  bool headers = true;  // --no-headers turns a table's header line off
};
Output& output();

rsdiscovery::ClientOptions client_options(const ParsedArgs& args);  // --no-wait-complete ...
rsdiscovery::Client make_client(const ParsedArgs& args);  // --endpoint and client_options()
rsdiscovery::DeviceFilter filter_from(const ParsedArgs& args);

// The warning for an answer taken before the daemon's first discovery ended.
void warn_incomplete();

// "rs-discover: no device 'KEY' (where the ids are; what says why one is missing)", on
// stderr: the one wording of every command that looks a camera up.
void report_no_device(const std::string& key);

// Prints "rs-discover: message" for an error and returns the exit code it maps to.
int report(const rsdiscovery::Error& error);

// Ends the process now with `status`, stdio flushed, and no destructor run: what a
// command built for its output (the devices, a table) is left to the exit, not freed
// one string at a time (a tenth of a cold `rs-discover list` of 100 cameras,
// bench/results/profile-cli-list.txt).
[[noreturn]] void exit_now(int status);

// ---- presentation ----------------------------------------------------------------------
namespace color {
extern const char* const bold;
extern const char* const green;
extern const char* const yellow;
extern const char* const red;
extern const char* const dim;
}  // namespace color
std::string paint(const std::string& text, const char* code);  // no-op without colour

std::string join(const std::vector<std::string>& parts, const std::string& sep);
std::string device_state(const rsdiscovery::Device& d);  // ok, recovery, warning
const char* state_color(const std::string& state);
std::string device_location(const rsdiscovery::Device& d);  // domain or USB port (and its host)
std::string device_addresses(const rsdiscovery::Device& d);
std::string device_sources(const rsdiscovery::Device& d);
// "5s", "3m", "2h", "4d" since an ISO 8601 UTC time; "-" when unreadable.
std::string age_since(const std::string& iso8601);
std::optional<double> parse_iso8601(const std::string& text);  // Unix seconds
// What the daemon knows of a missing expected camera: "last listed 12s ago, stopping",
// "never listed since the daemon started" (wait's and doctor's words alike).
std::string missing_since(const rsdiscovery::ExpectedCamera& camera);

// --format: TEMPLATE with {field} replaced by a field of the thing shown: any key of
// its document ({name}, {serial}, {fw-version} ...), a nested one with dots
// ({server.addresses}, {usb.port-path}); strings bare, lists joined by commas, other
// values as JSON, absent ones empty. {{ and }} are braces; \t and \n a tab and a line
// break. A brace left open or a field the thing does not have is a UsageError (exit 2)
// naming the fields there are.
class Template {
 public:
  // `known`: the fields the API documents, and those computed by the caller.
  Template(const std::string& text, std::vector<std::string> known);
  // A field neither documented nor in any of these documents (a device may carry
  // more of its device-info than the API documents) is an error.
  void check(const std::vector<const rsdiscovery::json::Value*>& docs) const;
  // `computed`: the value of a field that is not in the document ({state}, {age} ...).
  std::string render(const rsdiscovery::json::Value& doc,
                     const std::function<std::optional<std::string>(const std::string&)>& computed = {}) const;

 private:
  struct Piece {
    bool field;
    std::string text;  // literal text, or the field's dotted path
  };
  std::vector<Piece> pieces_;
  std::vector<std::string> known_;
};

// The fields of a device and of a participant, as the API documents them.
const std::vector<std::string>& device_fields();  // with {state}, {location}, {address}, {age}
const std::vector<std::string>& participant_fields();
// A device's value of {state}, {location}, {address}, {sources}, {age}.
std::optional<std::string> device_computed(const rsdiscovery::Device& d, const std::string& field);
// Checks `tmpl` against the devices, then prints each as it says, one a line.
void print_formatted(const Template& tmpl, const std::vector<rsdiscovery::Device>& devices);
inline constexpr OptionSpec kFormatOption = {"format", 'f', "TEMPLATE",
                                             "print each as TEMPLATE says ({name}, {server.addresses}, ...; see above)"};
// A JSON value as text: a string bare, a list joined by commas, null empty.
std::string value_text(const rsdiscovery::json::Value& v);

// A table like `docker ps`: columns padded to their widest cell, two spaces apart.
class Table {
 public:
  explicit Table(std::vector<std::string> headers) : headers_(std::move(headers)) {}
  // A whole row. colors: optional per cell colour codes (nullptr: none); missing cells
  // are empty.
  void add(std::vector<std::string> cells, std::vector<const char*> colors = {});
  // The next cell, left to right and row after row: a long table is filled without a
  // vector for each of its rows.
  void cell(std::string text, const char* color = nullptr);
  void reserve_rows(std::size_t rows);
  void print(std::FILE* out) const;

 private:
  std::vector<std::string> headers_;
  std::vector<std::string> cells_;    // row after row
  std::vector<const char*> colors_;   // each cell's
  std::vector<std::size_t> widths_;   // each cell's
};

// The subcommands, one per cmd_*.cpp file.
extern const Command kListCommand;
extern const Command kGetCommand;
extern const Command kDescribeCommand;
extern const Command kClientsCommand;
extern const Command kWatchCommand;
extern const Command kDomainsCommand;
extern const Command kParticipantsCommand;
extern const Command kDoctorCommand;
extern const Command kHealthCommand;
extern const Command kHistoryCommand;
extern const Command kWaitCommand;

}  // namespace rsdiscover
