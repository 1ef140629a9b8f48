#pragma once
// The scene config a user edits and a script writes (JSON), in one include. Each part has
// its own header:
//   Document.h      the file with its includes merged, and where each value came from
//   RenderConfig.h  what one run renders (the scene's parts: glTF files and generators,
//                   each placed by a transform; camera, lights and their shadow
//                   techniques, culling, size, frames), read and validated
//   Animation.h     keyframed tracks that script a run, and posing a frame
//   Sweep.h         parameter sweeps: one RenderConfig per variant
//   Overrides.h     --set technique.param=value
//   Run.h           preparing a run: the scene built from its parts, its lights, the
//                   overrides and sizes
//   ConfigWriter.h  a RenderConfig written back as a config file (the viewer's Save)
// config/schema/penumbra-config.schema.json describes the same format for editors.
#include "penumbra/config/Animation.h"
#include "penumbra/config/ConfigWriter.h"
#include "penumbra/config/Document.h"
#include "penumbra/config/Overrides.h"
#include "penumbra/config/RenderConfig.h"
#include "penumbra/config/Run.h"
#include "penumbra/config/Sweep.h"
