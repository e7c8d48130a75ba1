#include "faults/drive_fault.hpp"

namespace candp2::faults {

FaultyDrive::FaultyDrive(drive::UnitekDrive::Options options, LogSink* log,
                         drive::ParameterStore* store)
    : options_(std::move(options)), log_sink_(log), store_(store) {
  drive_.emplace(options_, log_sink_, store_);
}

void FaultyDrive::on_frame(const can::Frame& frame, Time now, can::FrameSink& out) {
  if (!muted_) drive_->on_frame(frame, now, out);  // muted: stops answering
}

void FaultyDrive::advance(Time now, can::FrameSink& out) {
  if (!muted_) drive_->advance(now, out);
}

std::optional<Time> FaultyDrive::next_deadline() const {
  return muted_ ? std::nullopt : drive_->next_deadline();
}

namespace {
// Where a muted drive's transmissions go.
struct Discard final : can::FrameSink {
  void send(const can::Frame&) override {}
};
}  // namespace

void FaultyDrive::set_muted(bool muted, Time now, can::FrameSink& out, std::string_view origin) {
  // Up to now: what was due before the change goes out (unless muted), the rest is lost.
  Discard discard;
  if (muted_) {
    drive_->advance(now, discard);
  } else {
    drive_->advance(now, out);
  }
  muted_ = muted;
  Logger(log_sink_, "drive:" + options_.name)
      .warn(std::string(muted_ ? "stops answering" : "answers again") + " (" + std::string(origin) +
            ")");
}

void FaultyDrive::set_error_bits(std::uint16_t bits, Time now, can::FrameSink& out) {
  errors_ = bits;
  drive_->set_errors((static_cast<std::uint32_t>(warnings_) << 16) | errors_, now, out);
}

void FaultyDrive::set_warning_bits(std::uint16_t bits, Time now, can::FrameSink& out) {
  warnings_ = bits;
  drive_->set_errors((static_cast<std::uint32_t>(warnings_) << 16) | errors_, now, out);
}

void FaultyDrive::restart(std::string_view origin) {
  Logger(log_sink_, "drive:" + options_.name)
      .warn("restart " + std::string(origin) + " (cyclic requests lost)");
  // Power-on state: stored parameters reloaded, cyclic transmissions and errors gone.
  drive_.emplace(options_, log_sink_, store_);
  errors_ = warnings_ = 0;
  muted_ = false;
}

std::uint16_t FaultyDrive::fault_register(std::uint16_t index) const {
  switch (index) {
    case kDriveMute:
      return muted_ ? 1 : 0;
    case kDriveErrorBits:
      return errors_;
    case kDriveWarningBits:
      return warnings_;
    default:
      return 0;
  }
}

void FaultyDrive::set_fault_register(std::uint16_t index, std::uint16_t value, Time now,
                                     can::FrameSink& out, std::string_view origin) {
  switch (index) {
    case kDriveMute:
      set_muted(value != 0, now, out, origin);
      return;
    case kDriveErrorBits:
      set_error_bits(value, now, out);
      return;
    case kDriveWarningBits:
      set_warning_bits(value, now, out);
      return;
    case kDriveRestart:
      if (value == 1) restart(origin);
      return;
  }
}

}  // namespace candp2::faults
