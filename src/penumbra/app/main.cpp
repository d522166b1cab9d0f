// The penumbra command-line tool; everything it does lives in the library (app/).
#include "penumbra/app/commands.h"

int main(int argc, char** argv) {
  return penumbra::runCli(argc, argv);
}
