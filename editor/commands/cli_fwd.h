#pragma once
// CLI11's App by name only. Headers take it by reference; the full <CLI/CLI.hpp> costs every file
// that includes it several seconds of compile time (twice that under sanitizers), so only the
// files that register or parse options include it.
namespace CLI {
class App;
class Option;
}
