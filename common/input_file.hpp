// Opening a user's input file (platform, job set, scene, profile, replay log, samples)
// with the message docs/architecture.md's "Bad input" asks for: the file named, and why it cannot be
// read. std::ifstream opens a folder without complaint and then reads nothing, which
// reached the parsers as "unexpected end of input"; open_input() says "is a folder".
#pragma once
#include <fstream>
#include <string>

namespace rayline {

// `what` names the kind of file in the message ("platform file", "scene profile").
// Throws InputError(path, "", ...) when path is missing, a folder or unreadable.
std::ifstream open_input(const std::string& path, const std::string& what);

}  // namespace rayline
