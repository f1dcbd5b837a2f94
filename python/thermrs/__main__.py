from thermrs.cli import main

main()
