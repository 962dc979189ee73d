#include "src/cli/app.h"

int main(int argc, char** argv) { return pano4d::cli::Main(argc, argv); }
