#include "capture/capture_writer.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>

#include "capture/pcapng.hpp"

namespace candp2::capture {

namespace {

class PosixFiles final : public FileSystem {
 public:
  int create(const std::string& path) override {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    return fd < 0 ? -errno : fd;
  }
  ssize_t write(int fd, const std::uint8_t* data, std::size_t n) override {
    return ::write(fd, data, n);
  }
  void close(int fd) override { ::close(fd); }
  void remove(const std::string& path) override { ::unlink(path.c_str()); }
};

// Written at once when the batch reaches this size; otherwise after each drain of the queue.
constexpr std::size_t kBatchBytes = 256 * 1024;

// The record in the queue: kind, 3 bytes padding, time (ns), then the block.
constexpr std::size_t kMetaLen = 12;

}  // namespace

std::unique_ptr<FileSystem> posix_files() {
  return std::make_unique<PosixFiles>();
}

std::string CaptureWriter::ring_name(const std::string& path, std::uint32_t number,
                                     std::uint64_t time_ns) {
  // dumpcap: PREFIX_NNNNN_YYYYmmddHHMMSS.SUFFIX, the suffix being the file name's extension.
  const auto slash = path.rfind('/');
  const auto dot = path.rfind('.');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash + 1);
  const std::string prefix = has_ext ? path.substr(0, dot) : path;
  const std::string suffix = has_ext ? path.substr(dot) : std::string();
  const std::time_t secs = static_cast<std::time_t>(time_ns / 1'000'000'000u);
  std::tm tm{};
  localtime_r(&secs, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d%H%M%S", &tm);
  char num[16];
  std::snprintf(num, sizeof num, "%05u", number);
  return prefix + "_" + num + "_" + stamp + suffix;
}

CaptureWriter::CaptureWriter(WriterOptions options, std::unique_ptr<FileSystem> fs)
    : options_(std::move(options)),
      fs_(fs ? std::move(fs) : posix_files()),
      queue_(options_.buffer_bytes),
      section_(pcapng::section_header(options_.application)),
      thread_([this] { run(); }) {}

CaptureWriter::~CaptureWriter() {
  stopping_.store(true, std::memory_order_release);
  signal_.fetch_add(1, std::memory_order_release);
  signal_.notify_one();
  thread_.join();
}

// ---------------------------------------------------------------- producer

bool CaptureWriter::push(Kind kind, std::span<const std::uint8_t> block, std::uint64_t time_ns) {
  if (failed_.load(std::memory_order_acquire)) return false;
  std::uint8_t meta[kMetaLen] = {static_cast<std::uint8_t>(kind)};
  std::memcpy(meta + 4, &time_ns, sizeof time_ns);
  if (!queue_.try_push({std::span<const std::uint8_t>(meta, kMetaLen), block})) return false;
  ++pushed_;
  signal_.fetch_add(1, std::memory_order_release);
  signal_.notify_one();  // a futex wake only while the writer sleeps
  return true;
}

bool CaptureWriter::add_header(std::span<const std::uint8_t> block, std::uint64_t time_ns) {
  return push(Kind::Header, block, time_ns);
}

bool CaptureWriter::add_packet(std::span<const std::uint8_t> block, std::uint64_t time_ns) {
  if (failed_.load(std::memory_order_acquire)) return false;
  if (!push(Kind::Packet, block, time_ns)) {
    ++dropped_;
    return false;
  }
  ++packets_;
  return true;
}

std::optional<std::string> CaptureWriter::take_failure() {
  if (failure_taken_ || !failed_.load(std::memory_order_acquire)) return std::nullopt;
  failure_taken_ = true;
  std::lock_guard lock(error_mutex_);
  return error_;
}

void CaptureWriter::sync() {
  const std::uint64_t target = pushed_;
  for (std::uint64_t done = processed_.load(std::memory_order_acquire); done < target;
       done = processed_.load(std::memory_order_acquire))
    processed_.wait(done, std::memory_order_acquire);
}

// ---------------------------------------------------------------- writer thread

void CaptureWriter::run() {
  std::vector<std::uint8_t> record;
  std::uint64_t processed = 0;
  while (true) {
    const std::uint32_t seen = signal_.load(std::memory_order_acquire);
    bool any = false;
    while (queue_.try_pop(record)) {
      any = true;
      if (record.size() >= kMetaLen && !failed_.load(std::memory_order_relaxed)) {
        std::uint64_t time_ns = 0;
        std::memcpy(&time_ns, record.data() + 4, sizeof time_ns);
        handle(static_cast<Kind>(record[0]), std::span(record).subspan(kMetaLen), time_ns);
      }
      ++processed;
      if (batch_.size() >= kBatchBytes) flush();
    }
    if (any) {
      flush();
      processed_.store(processed, std::memory_order_release);
      processed_.notify_all();
    }
    if (stopping_.load(std::memory_order_acquire) && queue_.empty()) break;
    if (!any) signal_.wait(seen, std::memory_order_acquire);
  }
  close_file();
}

void CaptureWriter::handle(Kind kind, std::span<const std::uint8_t> block, std::uint64_t time_ns) {
  if (kind == Kind::Header) {
    headers_.emplace_back(block.begin(), block.end());
    if (fd_ < 0) {
      open_next(time_ns);  // writes the section header and every header block
    } else {
      batch_.insert(batch_.end(), block.begin(), block.end());
    }
    return;
  }
  // A ring file is closed before a packet would take it past max_bytes (a file holds at least
  // one packet, however large).
  if (fd_ >= 0 && options_.max_bytes && file_packets_ > 0 &&
      file_bytes_ + batch_.size() + block.size() > options_.max_bytes) {
    if (!flush()) return;
    close_file();
  }
  if (fd_ < 0 && !open_next(time_ns)) return;
  batch_.insert(batch_.end(), block.begin(), block.end());
  ++file_packets_;
}

bool CaptureWriter::open_next(std::uint64_t time_ns) {
  const bool ring = options_.max_bytes > 0;
  ++number_;
  const std::string name = ring ? ring_name(options_.path, number_, time_ns) : options_.path;
  const int fd = fs_->create(name);
  if (fd < 0) {
    fail("cannot create " + name + ": " + std::strerror(-fd));
    return false;
  }
  fd_ = fd;
  file_ = name;
  file_bytes_ = 0;
  file_packets_ = 0;
  files_opened_.fetch_add(1, std::memory_order_relaxed);
  batch_ = section_;
  for (const auto& h : headers_) batch_.insert(batch_.end(), h.begin(), h.end());
  if (ring) {
    ring_.push_back(name);
    while (options_.files && ring_.size() > options_.files) {
      fs_->remove(ring_.front());
      ring_.pop_front();
    }
  }
  return true;
}

bool CaptureWriter::flush() {
  if (fd_ < 0 || batch_.empty()) return fd_ >= 0;
  std::size_t done = 0;
  while (done < batch_.size()) {
    const ssize_t n = fs_->write(fd_, batch_.data() + done, batch_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      fail("cannot write " + file_ + ": " + std::strerror(err));
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  file_bytes_ += done;
  bytes_written_.fetch_add(done, std::memory_order_relaxed);
  batch_.clear();
  return true;
}

void CaptureWriter::close_file() {
  if (fd_ < 0) return;
  flush();
  if (fd_ >= 0) fs_->close(fd_);
  fd_ = -1;
}

void CaptureWriter::fail(std::string message) {
  {
    std::lock_guard lock(error_mutex_);
    error_ = std::move(message);
  }
  failed_.store(true, std::memory_order_release);
  batch_.clear();
  if (fd_ >= 0) fs_->close(fd_);
  fd_ = -1;
}

}  // namespace candp2::capture
