#include "geardyn/csv.hpp"

#include <algorithm>
#include <string>
#include <thread>
#include <vector>

#include "geardyn/parallel.hpp"

namespace geardyn {
namespace {
// Blocks formatted per thread before the batch is handed to the stream.
constexpr std::size_t kBlocksPerThread = 4;
// Fewer blocks than this are written on the calling thread: the threads' start and the blocks'
// strings cost more than they save on a short file (the shipped loose gear's 6,224 rows).
constexpr std::size_t kFewestBlocksOnThreads = 4;
}  // namespace

void write_csv_rows(std::ostream& out, std::size_t count,
                    const std::function<void(CsvWriter&, std::size_t)>& write_row,
                    unsigned threads) {
  if (threads == 0) threads = std::max(1U, std::thread::hardware_concurrency());
  const std::size_t blocks = (count + kCsvRowsPerBlock - 1) / kCsvRowsPerBlock;
  if (threads == 1 || blocks < kFewestBlocksOnThreads) {
    CsvWriter csv(out);
    for (std::size_t i = 0; i < count; ++i) write_row(csv, i);
    csv.finish();
    return;
  }
  const std::size_t batch = kBlocksPerThread * threads;
  std::vector<std::string> text(std::min(batch, blocks));
  for (std::size_t first = 0; first < blocks; first += batch) {
    const std::size_t n = std::min(batch, blocks - first);
    parallel_for(n, threads, 0, {}, [&](std::size_t j, WorkTicker&) {
      CsvWriter csv;
      csv.text().swap(text[j]);
      csv.text().clear();
      const std::size_t begin = (first + j) * kCsvRowsPerBlock;
      const std::size_t end = std::min(count, begin + kCsvRowsPerBlock);
      for (std::size_t i = begin; i < end; ++i) write_row(csv, i);
      csv.text().swap(text[j]);
    });
    for (std::size_t j = 0; j < n; ++j)
      out.write(text[j].data(), static_cast<std::streamsize>(text[j].size()));
  }
}

}  // namespace geardyn
