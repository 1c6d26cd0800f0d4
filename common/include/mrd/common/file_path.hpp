#pragma once
// Plain string operations on file paths (no file system access), shared by the atomic writer
// and every reader that resolves one file's name against another's folder.

#include <string>

namespace mrd {

// The folder holding path: "." for a bare name, "/" for a name in the root folder, else
// path up to its last '/'.
std::string FolderOf(const std::string& path);

// The name after path's last '/' (path itself when it has none).
std::string BaseNameOf(const std::string& path);

// path as seen from the folder of file (a config, scenario or profile file naming another
// file): path unchanged when absolute, else FOLDER/path with FOLDER the text of file up to its
// last '/' ("." for a bare name). An empty path is relative (gives "FOLDER/").
std::string ResolveBeside(const std::string& file, const std::string& path);

}  // namespace mrd
