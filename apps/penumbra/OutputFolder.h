#pragma once
// `-o DIR` of the commands that write a set of files (compare, bench), and the folder of
// `bench --summary FILE`: "out/" names the folder "out"; it is created when missing (its
// parent must exist), once the run has succeeded; files in it that are not the command's
// are left alone; every file is written to a temporary name and renamed
// (io/StagedFile.h), so a failed or interrupted run leaves complete files only.
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::app {

// The folder that `-o` names ("out/" and "out" alike).
std::filesystem::path outputFolder(const std::string& flag);

// Fails (penumbra::Error naming `who`: "-o out") before any work when the folder cannot be
// created, or exists and one of `files` in it could not be written.
void checkOutputFolder(const std::filesystem::path& dir, const std::vector<std::filesystem::path>& files,
                       const std::string& who);

// Creates the folder when missing (checkOutputFolder said that it can be).
void createOutputFolder(const std::filesystem::path& dir, const std::string& who);

} // namespace penumbra::app
