// Crash-safe file output. A reader of PATH sees either its old content or the
// complete new one, never a prefix: the content goes to a temporary file in
// the same directory, is fsync'ed, then renamed over PATH (rename is atomic
// within a file system) and the directory is fsync'ed. Every write, fsync,
// close and rename is checked; any failure throws std::runtime_error naming
// the file and the system's reason (e.g. "No space left on device").
#pragma once

#include <string>

namespace agnc_pgo {
namespace core {

// Replaces PATH by CONTENT atomically. If PATH exists and is not a regular
// file (a device such as /dev/null or /dev/full, a FIFO), it is written in
// place instead, since it cannot be replaced; errors are still reported.
void writeFileAtomically(const std::string& path, const std::string& content);

// Two-phase writes for files that must change together (a g2o file and its
// sidecar): stage every file first (written to stagingPath(PATH) and
// fsync'ed), then commit them one by one. A crash before the first commit
// leaves every old file intact; the staged files can tell a reader which new
// file belongs with which (the sidecar's checksum of its g2o file).
std::string stagingPath(const std::string& path);
void stageFile(const std::string& path, const std::string& content);
void commitStagedFile(const std::string& path);

// Reads a whole file; throws std::runtime_error if it cannot be opened or
// read or is larger than max_bytes.
std::string readWholeFile(const std::string& path, std::size_t max_bytes);

// CRC-32 (IEEE 802.3, as zlib and boost::crc_32_type) of the bytes.
unsigned long crc32Of(const std::string& bytes);

}  // namespace core
}  // namespace agnc_pgo
