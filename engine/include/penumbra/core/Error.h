#pragma once
// Errors for bad input and API misuse (STYLE.md: exceptions with a message that says
// where and what). Programmer errors are assertions, not exceptions.
#include <stdexcept>
#include <string>

namespace penumbra {

// Base class: everything the engine throws for bad input derives from it, so an app
// can catch one type, print what() and exit non-zero.
class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// The Vulkan driver, device or a Vulkan call failed.
class GpuError : public Error {
public:
    using Error::Error;
};

// A GLSL file failed to compile; what() lists "file:line: message" lines.
class ShaderCompileError : public Error {
public:
    using Error::Error;
};

// A config file is missing, malformed or invalid; what() names file and JSON path.
class ConfigError : public Error {
public:
    using Error::Error;
};

// A scene file (glTF) is missing, malformed, or needs a feature penumbra does not
// support; what() names the file and the element: "a.gltf: /accessors/3: ...".
class AssetError : public Error {
public:
    using Error::Error;
};

} // namespace penumbra
