#include "agnc_pgo/core/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <vector>

#include <boost/crc.hpp>

namespace agnc_pgo {
namespace core {
namespace {

[[noreturn]] void failWith(const std::string& what, const std::string& path, int error) {
  throw std::runtime_error("cannot " + what + " '" + path + "': " + std::strerror(error));
}

std::string directoryOf(const std::string& path) {
  const std::string::size_type slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

void writeAll(int fd, const std::string& content, const std::string& path) {
  const char* data = content.data();
  std::size_t left = content.size();
  while (left > 0) {
    const ssize_t written = ::write(fd, data, left);
    if (written < 0) {
      if (errno == EINTR) continue;
      const int error = errno;
      ::close(fd);
      failWith("write", path, error);
    }
    data += written;
    left -= static_cast<std::size_t>(written);
  }
}

// fsync of a device or FIFO may legitimately be unsupported (EINVAL/EROFS).
void syncAndClose(int fd, const std::string& path, bool regular) {
  if (::fsync(fd) != 0 && (regular || (errno != EINVAL && errno != EROFS))) {
    const int error = errno;
    ::close(fd);
    failWith("fsync", path, error);
  }
  if (::close(fd) != 0) failWith("close", path, errno);
}

void syncDirectory(const std::string& path) {
  const std::string directory = directoryOf(path);
  const int fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) failWith("open directory", directory, errno);
  const int status = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  if (status != 0) failWith("fsync directory", directory, error);
}

bool isSpecialFile(const std::string& path) {
  struct stat info;
  return ::stat(path.c_str(), &info) == 0 && !S_ISREG(info.st_mode);
}

void writeInPlace(const std::string& path, const std::string& content) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  if (fd < 0) failWith("open", path, errno);
  writeAll(fd, content, path);
  syncAndClose(fd, path, false);
}

void writeNewFile(const std::string& path, const std::string& content, int flags) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | flags, 0644);
  if (fd < 0) failWith("create", path, errno);
  writeAll(fd, content, path);
  syncAndClose(fd, path, true);
}

}  // namespace

std::string stagingPath(const std::string& path) { return path + ".saving"; }

void stageFile(const std::string& path, const std::string& content) {
  if (isSpecialFile(path)) throw std::runtime_error("cannot save to '" + path + "': not a regular file");
  writeNewFile(stagingPath(path), content, O_TRUNC);
}

void commitStagedFile(const std::string& path) {
  if (::rename(stagingPath(path).c_str(), path.c_str()) != 0) failWith("rename to", path, errno);
  syncDirectory(path);
}

void writeFileAtomically(const std::string& path, const std::string& content) {
  if (isSpecialFile(path)) return writeInPlace(path, content);
  // A unique temporary: concurrent writers of one path never share it.
  std::string temporary = path + ".tmp.XXXXXX";
  std::vector<char> name(temporary.begin(), temporary.end());
  name.push_back('\0');
  const int fd = ::mkstemp(name.data());
  if (fd < 0) failWith("create a temporary file for", path, errno);
  temporary = name.data();
  try {
    ::fchmod(fd, 0644);
    writeAll(fd, content, temporary);
    syncAndClose(fd, temporary, true);
    if (::rename(temporary.c_str(), path.c_str()) != 0) failWith("rename to", path, errno);
    syncDirectory(path);
  } catch (...) {
    ::unlink(temporary.c_str());
    throw;
  }
}

std::string readWholeFile(const std::string& path, std::size_t max_bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open '" + path + "'");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw std::runtime_error("cannot read '" + path + "'");
  if (static_cast<std::size_t>(size) > max_bytes)
    throw std::runtime_error("'" + path + "' is larger than " + std::to_string(max_bytes) + " bytes");
  std::string content(static_cast<std::size_t>(size), '\0');
  in.seekg(0, std::ios::beg);
  if (size > 0) in.read(&content[0], size);
  if (!in) throw std::runtime_error("cannot read '" + path + "'");
  return content;
}

unsigned long crc32Of(const std::string& bytes) {
  boost::crc_32_type crc;
  crc.process_bytes(bytes.data(), bytes.size());
  return crc.checksum();
}

}  // namespace core
}  // namespace agnc_pgo
