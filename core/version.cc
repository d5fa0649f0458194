#include "core/version.h"

namespace ieslam {

const char* IeslamVersion() { return IESLAM_VERSION; }

}  // namespace ieslam
