// The pcapng capture file writer (docs/capture.md): one file, or a ring of files of a maximum
// size like dumpcap's `-b filesize:… -b files:…`, written by a thread of its own so the event loop
// never waits for the disk. The producer (the event loop: the plant's taps) hands over finished
// pcapng blocks through a bounded lock-free queue (spsc_queue.hpp); when the writer falls behind
// and the queue is full, packets are dropped and counted, never waited for. A write error (a full
// disk, ENOSPC) stops the capture: the producer learns it once (take_failure(), for one log
// line) and every later packet is ignored; the daemon goes on. Decisions: docs/decisions.md
// "pcapng captures".
//
// File names (ring mode, max_bytes > 0), as dumpcap names them: PATH "dir/cap.pcapng" gives
// dir/cap_00001_20240131120000.pcapng, dir/cap_00002_… (5-digit sequence number, the local time
// of the file's first packet as YYYYmmddHHMMSS); with `files` = K only the newest K files are
// kept. Without max_bytes the capture is one file at PATH (overwritten at start).
#pragma once

#include <sys/types.h>

#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "capture/spsc_queue.hpp"

namespace candp2::capture {

// What the writer thread does to the file system; tests replace it (a full disk, a failing open).
class FileSystem {
 public:
  virtual ~FileSystem() = default;
  // Creates (or truncates) `path` for writing: a descriptor, or -errno.
  virtual int create(const std::string& path) = 0;
  // write(2): bytes written (may be fewer than n), or -1 with errno set.
  virtual ssize_t write(int fd, const std::uint8_t* data, std::size_t n) = 0;
  virtual void close(int fd) = 0;
  virtual void remove(const std::string& path) = 0;
};
// The real one: open(2) with O_CLOEXEC, write(2), close(2), unlink(2).
std::unique_ptr<FileSystem> posix_files();

struct WriterOptions {
  std::string path;             // PATH of the configuration
  std::uint64_t max_bytes = 0;  // ring: a file is closed before it would exceed this; 0 = one file
  std::uint32_t files = 0;      // ring: keep the newest `files` files; 0 = keep all
  std::size_t buffer_bytes = std::size_t{8} << 20;  // the queue between producer and writer
  std::string application = "candp2";               // the Section Header's shb_userappl
};

class CaptureWriter {
 public:
  explicit CaptureWriter(WriterOptions options, std::unique_ptr<FileSystem> fs = nullptr);
  // Writes what is queued, closes the file, stops the thread.
  ~CaptureWriter();
  CaptureWriter(const CaptureWriter&) = delete;
  CaptureWriter& operator=(const CaptureWriter&) = delete;

  // ---- producer side (one thread) ----
  // A header block (an Interface Description Block) that every file of the capture repeats after
  // its Section Header; `time_ns` names the first file when it comes first. False when the queue
  // is full or the capture stopped (the caller tries again with its next packet).
  bool add_header(std::span<const std::uint8_t> block, std::uint64_t time_ns);
  // One packet block (an Enhanced Packet Block). False when dropped: the queue is full (counted
  // in dropped()) or the capture stopped.
  bool add_packet(std::span<const std::uint8_t> block, std::uint64_t time_ns);
  // The writer's error message, the first time it is asked after the capture stopped.
  std::optional<std::string> take_failure();
  bool stopped() const { return failed_.load(std::memory_order_acquire); }
  std::uint64_t packets() const { return packets_; }  // accepted into the queue
  std::uint64_t dropped() const { return dropped_; }  // refused: the queue was full
  // Waits until everything accepted so far is written (or the capture stopped). For tests and
  // shutdown; the event loop never calls it.
  void sync();

  // ---- either side ----
  std::uint64_t bytes_written() const { return bytes_written_.load(std::memory_order_relaxed); }
  std::uint32_t files_opened() const { return files_opened_.load(std::memory_order_relaxed); }
  const WriterOptions& options() const { return options_; }

  // The name of ring file `number` (1..) whose first packet is at `time_ns` (local time).
  static std::string ring_name(const std::string& path, std::uint32_t number,
                               std::uint64_t time_ns);

 private:
  enum class Kind : std::uint8_t { Header = 1, Packet = 2 };
  bool push(Kind kind, std::span<const std::uint8_t> block, std::uint64_t time_ns);

  // writer thread
  void run();
  void handle(Kind kind, std::span<const std::uint8_t> block, std::uint64_t time_ns);
  bool open_next(std::uint64_t time_ns);
  void close_file();
  bool flush();
  void fail(std::string message);

  WriterOptions options_;
  std::unique_ptr<FileSystem> fs_;
  SpscByteQueue queue_;

  // producer
  std::uint64_t packets_ = 0;
  std::uint64_t dropped_ = 0;
  std::uint64_t pushed_ = 0;  // records accepted
  bool failure_taken_ = false;

  // shared
  std::atomic<std::uint32_t> signal_{0};     // bumped after each push: wakes the writer
  std::atomic<std::uint64_t> processed_{0};  // records the writer has handled
  std::atomic<bool> stopping_{false};
  std::atomic<bool> failed_{false};
  std::mutex error_mutex_;
  std::string error_;
  std::atomic<std::uint64_t> bytes_written_{0};
  std::atomic<std::uint32_t> files_opened_{0};

  // writer thread only
  std::vector<std::uint8_t> section_;               // the Section Header Block
  std::vector<std::vector<std::uint8_t>> headers_;  // Interface Description Blocks so far
  std::vector<std::uint8_t> batch_;                 // bytes for the current file, not yet written
  int fd_ = -1;
  std::string file_;
  std::uint64_t file_bytes_ = 0;  // written to the current file (batch not included)
  std::uint64_t file_packets_ = 0;
  std::uint32_t number_ = 0;
  std::deque<std::string> ring_;

  std::thread thread_;  // last: starts after everything above is set up
};

}  // namespace candp2::capture
