// geardyn: the rows of the time-series files (timeseries.csv of every model).
//
// Numbers are written with std::to_chars at 10 significant digits, the text printf's "%.10g"
// gives, without a format string read for every number; rows collect in a buffer handed to the
// stream in large blocks. write_csv_rows formats a file's rows in blocks on several threads and
// hands them to the stream in order: the same text as one writer row by row.
#pragma once

#include <charconv>
#include <cstddef>
#include <functional>
#include <ostream>
#include <string>
#include <string_view>

namespace geardyn {

class CsvWriter {
 public:
  static constexpr int kSignificantDigits = 10;
  // Rows handed to `out` in blocks of about kBlockBytes.
  explicit CsvWriter(std::ostream& out) : out_(&out) { buffer_.reserve(kBlockBytes + 1024); }
  // Rows kept in text() until taken.
  CsvWriter() = default;
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;
  // The rows not yet handed to the stream are lost unless finish() was called.
  ~CsvWriter() = default;

  // The next field of the row, a comma before it unless it is the row's first.
  CsvWriter& number(double x) {
    separate();
    char text[32];
    const auto r =
        std::to_chars(text, text + sizeof text, x, std::chars_format::general, kSignificantDigits);
    buffer_.append(text, r.ptr);
    return *this;
  }
  CsvWriter& integer(long long n) {
    separate();
    char text[24];
    const auto r = std::to_chars(text, text + sizeof text, n);
    buffer_.append(text, r.ptr);
    return *this;
  }
  CsvWriter& text(std::string_view s) {
    separate();
    buffer_.append(s);
    return *this;
  }
  void end_row() {
    buffer_.push_back('\n');
    first_ = true;
    if (out_ && buffer_.size() >= kBlockBytes) flush();
  }
  // Hands every complete row to the stream.
  void finish() { flush(); }
  // The rows written so far, without a stream.
  std::string& text() { return buffer_; }

 private:
  static constexpr std::size_t kBlockBytes = std::size_t{1} << 16;
  void separate() {
    if (!first_) buffer_.push_back(',');
    first_ = false;
  }
  void flush() {
    if (!out_) return;
    out_->write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }
  std::ostream* out_ = nullptr;
  std::string buffer_;
  bool first_ = true;
};

// Writes rows 0 .. count - 1 to `out` in order, row i by write_row(csv, i) (its fields, then
// csv.end_row()). A file of a few blocks of kCsvRowsPerBlock rows or more is formatted a block
// per job on up to `threads` threads at a time (0: every core; parallel.hpp), the blocks handed
// to the stream in their order, a few blocks per thread in memory at once; a shorter file is
// written on the calling thread. write_row is called once per row, from any
// of those threads, and must only read what it shares. The text is the same whatever the
// threads (tests/output_test.cpp).
constexpr std::size_t kCsvRowsPerBlock = 4096;
void write_csv_rows(std::ostream& out, std::size_t count,
                    const std::function<void(CsvWriter&, std::size_t)>& write_row,
                    unsigned threads = 0);

}  // namespace geardyn
