// files/private_folder: a file written whole is renamed into place only over a regular file or
// nothing. A FIFO, a socket, a folder, a symbolic link (/dev/stdout is one) or a device at the
// name is refused by name and left as it was (issue 49: `view -o /dev/null` as root replaced
// the system's device node). The CLI's writers (view, generate) through it: test_plan_command.
#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/un.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "private_folder.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

namespace fs = std::filesystem;

class PrivateFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() / ("spacearm_private_folder_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  // replace_file on `name` must throw naming it and its kind, and leave it as it was.
  void expect_refused(const std::string& name, const std::string& kind) {
    const std::string path = (dir / name).string();
    struct stat before {};
    ASSERT_EQ(::lstat(path.c_str(), &before), 0);
    EXPECT_THROW_MESSAGE(replace_file(path, "<html>page</html>\n"), FolderError,
                         "'" + path + "' exists and is " + kind + ", not a regular file");
    struct stat after {};
    ASSERT_EQ(::lstat(path.c_str(), &after), 0);
    EXPECT_EQ(after.st_ino, before.st_ino) << path << " was replaced";
    EXPECT_EQ(after.st_mode & S_IFMT, before.st_mode & S_IFMT);
    // No temporary left beside it.
    for (const auto& e : fs::directory_iterator(dir))
      EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos)
          << "a temporary was left: " << e.path();
  }

  fs::path dir;
};

TEST_F(PrivateFolder, ReplacesARegularFileWholeOrCreatesIt) {
  const std::string path = (dir / "page.html").string();
  replace_file(path, "first\n");
  EXPECT_EQ(test::read_text_file(path), "first\n");
  replace_file(path, "second\n");
  EXPECT_EQ(test::read_text_file(path), "second\n");
}

TEST_F(PrivateFolder, AFifoIsRefusedNotReplaced) {
  ASSERT_EQ(::mkfifo((dir / "pipe").c_str(), 0600), 0);
  expect_refused("pipe", "a FIFO (named pipe)");
}

TEST_F(PrivateFolder, ALinkIsRefusedNotReplacedNorWrittenThrough) {
  std::ofstream(dir / "target") << "kept\n";
  fs::create_symlink(dir / "target", dir / "link");
  expect_refused("link", "a symbolic link");
  EXPECT_EQ(test::read_text_file((dir / "target").string()), "kept\n");
  // The way /dev/stdout reaches a terminal or a pipe.
  fs::create_symlink("/proc/self/fd/1", dir / "stdout");
  expect_refused("stdout", "a symbolic link");
}

TEST_F(PrivateFolder, ASocketAndAFolderAreRefused) {
  const int s = ::socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(s, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string path = (dir / "socket").string();
  ASSERT_LT(path.size(), sizeof addr.sun_path);
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  ASSERT_EQ(::bind(s, reinterpret_cast<const sockaddr*>(&addr), sizeof addr), 0);
  expect_refused("socket", "a socket");
  ::close(s);
  fs::remove(dir / "socket");
  fs::create_directories(dir / "folder");
  expect_refused("folder", "a folder");
}

// A character device like /dev/null: made with mknod where this user may (root, in CI's
// container), else the test says why it is skipped.
TEST_F(PrivateFolder, ACharacterDeviceIsRefusedNotReplaced) {
  if (::mknod((dir / "null").c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0)
    GTEST_SKIP() << "mknod needs privileges here: " << std::strerror(errno);
  expect_refused("null", "a character device");
}

}  // namespace
}  // namespace spacearm
