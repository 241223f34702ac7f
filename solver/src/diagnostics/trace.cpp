#include "hdeform/trace.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <memory>
#include <mutex>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "hdeform/atomic_file.h"

namespace hdeform::trace {
namespace detail {

std::atomic<bool> enabled{false};

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace detail

namespace {

enum class Kind : std::uint8_t { Complete, Counter, Instant };

struct Event {
  const char* name;
  const char* category;
  const char* track;  // a track of its own instead of the thread's, or null
  std::int64_t begin_ns;
  std::int64_t end_ns;
  double value;  // counter value; complete: the argument (negative: none)
  Kind kind;
};

// One thread's events. Only that thread writes; a writer reads [0, count) at any time.
struct Buffer {
  Buffer(std::size_t size, int number) : events(new Event[size]), capacity(size), id(number), os_thread(::gettid()) {}
  std::unique_ptr<Event[]> events;
  std::size_t capacity;
  std::atomic<std::size_t> count{0};
  std::atomic<std::size_t> dropped{0};
  int id;
  long os_thread;
  std::atomic<const char*> name{nullptr};
};

struct Recording {
  std::mutex mutex;
  std::vector<std::unique_ptr<Buffer>> buffers;
  std::size_t capacity = 0;
  std::int64_t origin_ns = 0;
  std::atomic<std::uint64_t> generation{0};
};

Recording& recording() {
  static Recording instance;
  return instance;
}

std::atomic<std::uint64_t> calls{0};
thread_local Buffer* local_buffer = nullptr;
thread_local std::uint64_t local_generation = 0;
thread_local const char* local_name = nullptr;

Buffer* this_thread_buffer() {
  Recording& r = recording();
  const std::uint64_t generation = r.generation.load(std::memory_order_acquire);
  if (local_buffer != nullptr && local_generation == generation) return local_buffer;
  // The first event of this thread in this recording: the one allocation it makes.
  std::lock_guard lock(r.mutex);
  r.buffers.push_back(std::make_unique<Buffer>(r.capacity, static_cast<int>(r.buffers.size()) + 1));
  local_buffer = r.buffers.back().get();
  local_buffer->name.store(local_name, std::memory_order_relaxed);
  local_generation = generation;
  return local_buffer;
}

void append(const Event& event) {
  calls.fetch_add(1, std::memory_order_relaxed);
  Buffer* buffer = this_thread_buffer();
  const std::size_t n = buffer->count.load(std::memory_order_relaxed);
  if (n >= buffer->capacity) {
    buffer->dropped.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  buffer->events[n] = event;
  buffer->count.store(n + 1, std::memory_order_release);
}

void append_escaped(std::string& out, std::string_view text) {
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      out += ' ';
    } else {
      out += c;
    }
  }
}

void append_number(std::string& out, double value) {
  std::array<char, 32> text;
  const auto result = std::to_chars(text.data(), text.data() + text.size(), value);
  out.append(text.data(), result.ptr);
}

// Microseconds since the recording started, to the nanosecond.
void append_time(std::string& out, std::int64_t ns, std::int64_t origin_ns) {
  const std::int64_t relative = ns - origin_ns;
  out += std::to_string(relative / 1000);
  const auto fraction = static_cast<int>(std::abs(relative % 1000));
  out += '.';
  out += static_cast<char>('0' + fraction / 100);
  out += static_cast<char>('0' + fraction / 10 % 10);
  out += static_cast<char>('0' + fraction % 10);
}

}  // namespace

void detail::complete(const char* name, const char* category, std::int64_t begin_ns, std::int64_t end_ns, std::int64_t arg) {
  append({name, category, nullptr, begin_ns, end_ns, static_cast<double>(arg), Kind::Complete});
}

void start(std::size_t events_per_thread) {
  Recording& r = recording();
  {
    std::lock_guard lock(r.mutex);
    r.buffers.clear();
    r.capacity = std::max<std::size_t>(events_per_thread, 16);
    r.origin_ns = detail::now_ns();
    r.generation.fetch_add(1, std::memory_order_release);
  }
  detail::enabled.store(true, std::memory_order_release);
}

void stop() { detail::enabled.store(false, std::memory_order_release); }
void resume() { detail::enabled.store(true, std::memory_order_release); }

std::uint64_t recorder_calls() { return calls.load(std::memory_order_relaxed); }

std::size_t recorded_events() {
  Recording& r = recording();
  std::lock_guard lock(r.mutex);
  std::size_t total = 0;
  for (const auto& buffer : r.buffers) total += buffer->count.load(std::memory_order_acquire);
  return total;
}

void complete(const char* name, const char* category, std::int64_t begin_ns, std::int64_t end_ns, const char* track) {
  if (!enabled()) return;
  append({name, category, track, begin_ns, end_ns, -1.0, Kind::Complete});
}

void counter(const char* name, double value) {
  if (!enabled()) return;
  const std::int64_t now = detail::now_ns();
  append({name, "counter", nullptr, now, now, value, Kind::Counter});
}

void instant(const char* name, const char* category) {
  if (!enabled()) return;
  const std::int64_t now = detail::now_ns();
  append({name, category, nullptr, now, now, 0.0, Kind::Instant});
}

void name_thread(const char* name) {
  local_name = name;
  if (local_buffer != nullptr) local_buffer->name.store(name, std::memory_order_relaxed);
}

void write(const std::filesystem::path& path) {
  Recording& r = recording();
  std::string out;
  {
    std::lock_guard lock(r.mutex);
    const long pid = ::getpid();
    const std::string process = ",\"pid\":" + std::to_string(pid);
    std::vector<const char*> tracks;  // named tracks get ids after the threads'
    const auto track_id = [&](const char* track) {
      const auto it = std::find_if(tracks.begin(), tracks.end(), [&](const char* t) { return std::string_view(t) == track; });
      if (it != tracks.end()) return static_cast<int>(r.buffers.size() + 1 + static_cast<std::size_t>(it - tracks.begin()));
      tracks.push_back(track);
      return static_cast<int>(r.buffers.size() + tracks.size());
    };
    std::size_t dropped = 0;
    out += "{\"displayTimeUnit\":\"ms\",\"traceEvents\":[\n";
    bool first = true;
    const auto separate = [&] {
      if (!first) out += ",\n";
      first = false;
    };
    for (const auto& buffer : r.buffers) {
      const std::size_t count = buffer->count.load(std::memory_order_acquire);
      dropped += buffer->dropped.load(std::memory_order_relaxed);
      const char* name = buffer->name.load(std::memory_order_relaxed);
      separate();
      out += "{\"ph\":\"M\",\"name\":\"thread_name\"" + process + ",\"tid\":" + std::to_string(buffer->id) + ",\"args\":{\"name\":\"";
      append_escaped(out, name != nullptr ? name : "worker");
      out += " (thread " + std::to_string(buffer->os_thread) + ")\"}}";
      // Per thread in order of start, the enclosing event first: the order viewers nest by.
      std::vector<const Event*> events(count);
      for (std::size_t k = 0; k < count; ++k) events[k] = &buffer->events[k];
      std::stable_sort(events.begin(), events.end(), [](const Event* a, const Event* b) {
        return a->begin_ns != b->begin_ns ? a->begin_ns < b->begin_ns : a->end_ns > b->end_ns;
      });
      for (const Event* event : events) {
        separate();
        out += "{\"name\":\"";
        append_escaped(out, event->name);
        out += "\",\"cat\":\"";
        append_escaped(out, event->category);
        out += "\"" + process + ",\"tid\":" + std::to_string(event->track != nullptr ? track_id(event->track) : buffer->id) + ",\"ts\":";
        append_time(out, event->begin_ns, r.origin_ns);
        switch (event->kind) {
          case Kind::Complete:
            out += ",\"ph\":\"X\",\"dur\":";
            append_time(out, event->end_ns - event->begin_ns + r.origin_ns, r.origin_ns);
            if (event->value >= 0.0) {
              out += ",\"args\":{\"n\":";
              append_number(out, event->value);
              out += "}";
            }
            break;
          case Kind::Counter:
            out += ",\"ph\":\"C\",\"args\":{\"value\":";
            append_number(out, event->value);
            out += "}";
            break;
          case Kind::Instant: out += ",\"ph\":\"i\",\"s\":\"t\""; break;
        }
        out += "}";
      }
    }
    for (std::size_t k = 0; k < tracks.size(); ++k) {
      separate();
      out += "{\"ph\":\"M\",\"name\":\"thread_name\"" + process + ",\"tid\":" + std::to_string(r.buffers.size() + 1 + k) + ",\"args\":{\"name\":\"";
      append_escaped(out, tracks[k]);
      out += "\"}}";
    }
    out += "\n],\"otherData\":{\"dropped_events\":" + std::to_string(dropped) + "}}\n";
  }
  write_file_atomically(path, [&](std::ostream& stream) { stream.write(out.data(), static_cast<std::streamsize>(out.size())); });
}

}  // namespace hdeform::trace
