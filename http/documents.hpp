// GET /api/v1/status and GET /metrics assembled in small steps (docs/daemon.md "Cost"). Each step
// is built between two loop callbacks, so each piece (a gateway without its slots, a few slot rows,
// a bus with its trace, one metric family) is consistent in itself; the server runs steps while
// its budget for a loop turn lasts and answers every request waiting for the document when the
// last step is done. The documents are the ones StatusModel::status() and metrics() build in one
// piece.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "common/time.hpp"
#include "http/http_status.hpp"
#include "station/status.hpp"

namespace candp2::http {

class DocumentBuild {
 public:
  virtual ~DocumentBuild() = default;
  // One step; true when the document is complete (then take() it).
  virtual bool step(Time now) = 0;
  virtual bool started() const = 0;
  std::string take() { return std::move(out_); }

 protected:
  // `expected`: the size of the last document, reserved at once (growing a megabyte string
  // copies it: one step would take as long as many).
  explicit DocumentBuild(std::size_t expected) { out_.reserve(expected + expected / 4); }
  std::string out_;
};

// The head (cycle, Modbus, HTTP), each bus with its trace, the drives, then each gateway without
// its slots, then its slot rows a few at a time. Members in another order than status().
class StatusBuild final : public DocumentBuild {
 public:
  StatusBuild(StatusModel& model, std::size_t expected) : DocumentBuild(expected), model_(model) {}
  bool step(Time now) override;
  bool started() const override { return started_; }

 private:
  StatusModel& model_;
  bool started_ = false;
  bool done_ = false;
  std::size_t bus_ = 0;
  bool drives_ = false;
  std::size_t gateway_ = 0;
  std::size_t row_ = 0;
  std::size_t rows_ = 0;
  bool in_gateway_ = false;
  bool slaves_open_ = false;  // the gateways are done: "slaves" one a step
  std::size_t slave_ = 0;
};

// Prometheus text format 0.0.4: the gateways' and the generic slaves' statuses a few at a
// time, then one metric family per step.
class MetricsBuild final : public DocumentBuild {
 public:
  MetricsBuild(StatusModel& model, std::size_t expected) : DocumentBuild(expected), model_(model) {}
  bool step(Time now) override;
  bool started() const override { return started_; }

 private:
  void family(std::string_view name, std::string_view type, std::string_view help);
  struct Row {
    std::string labels;
    station::Status status;
  };
  // One family of the station table (station/status.hpp) over the gateways' or slaves' rows.
  void per_row(const station::Field& f, const station::Metric& m, const std::vector<Row>& rows);
  void tail();
  void timed_buses();
  Time now_{0};

  StatusModel& model_;
  bool started_ = false;
  std::vector<Row> rows_;
  std::vector<Row> slave_rows_;  // the generic slaves' statuses
  std::size_t family_ = 0;
  std::size_t slave_family_ = 0;
  bool done_ = false;
};

}  // namespace candp2::http
