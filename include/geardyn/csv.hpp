// geardyn: the rows of the time-series files (timeseries.csv of every model).
//
// Numbers are written with std::to_chars at 10 significant digits, the text printf's "%.10g"
// gives, without a format string read for every number; rows collect in a buffer handed to the
// stream in large blocks.
#pragma once

#include <charconv>
#include <cstddef>
#include <ostream>
#include <string>
#include <string_view>

namespace geardyn {

class CsvWriter {
 public:
  static constexpr int kSignificantDigits = 10;
  explicit CsvWriter(std::ostream& out) : out_(out) { buffer_.reserve(kBlockBytes + 1024); }
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
    if (buffer_.size() >= kBlockBytes) flush();
  }
  // Hands every complete row to the stream.
  void finish() { flush(); }

 private:
  static constexpr std::size_t kBlockBytes = std::size_t{1} << 16;
  void separate() {
    if (!first_) buffer_.push_back(',');
    first_ = false;
  }
  void flush() {
    out_.write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }
  std::ostream& out_;
  std::string buffer_;
  bool first_ = true;
};

}  // namespace geardyn
