// Reading an image file whole, refusing one that ends early. Decoders fill the rows a truncated
// file lacks (libjpeg with grey and a "Premature end of JPEG file" line on stderr), so a cut
// image would otherwise be used as if it were whole.
//
// Completeness is checked on the bytes, per format, before decoding:
//  - JPEG: an end-of-image marker FF D9 follows the last start-of-scan marker FF DA (padding
//    and trailers after the image, such as a second MPO frame, are allowed).
//  - PNG (8- and 16-bit): the chunk chain from the signature reaches an IEND chunk, each
//    chunk inside the file (bytes after IEND are allowed), and the CRC of every critical chunk
//    (IHDR, PLTE, IDAT, IEND) matches: a damaged PNG is refused naming the file before libpng
//    fails on it with an unattributed line on stderr.
//  - binary PGM / PPM (P5, P6): the header's width x height x channels x bytes-per-sample of
//    pixel data follow it.
//  - BMP: the file is at least as long as its header's file size.
// Other formats (TIFF, WebP, ASCII PNM, ...) are caught only when they fail to decode. A JPEG
// cut before its first scan passes when an embedded thumbnail is complete; it then fails to
// decode.
// JPEG has no checksum: a complete JPEG damaged inside decodes with libjpeg's "Corrupt JPEG
// data" warning on stderr and is used.
#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace ieslam {

// What is wrong with `bytes` (a whole image file) by the checks above, as "truncated: why" or
// "damaged: why"; "" when it passes them or its format has no check.
std::string ImageFileDefect(const std::string& bytes);

// Reads `path` into memory once (ReadInputFile: a regular file of at most kMaxImageBytes),
// checks ImageFileDefect and decodes (cv::imdecode with `flags`). Throws DataError naming
// `what` ("colour image") and the file when it is missing, not a regular file, too large,
// empty, incomplete or does not decode.
cv::Mat ReadImageFile(const std::string& path, int flags, const std::string& what = "image");

}  // namespace ieslam
