// The project's version, as reports and `ieslam --version` give it.
#pragma once

namespace ieslam {

const char* IeslamVersion();

}  // namespace ieslam
